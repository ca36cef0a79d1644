"""grainfrac: grain-scale hydro-mechanical fracturing of crystalline rock."""

__version__ = "0.1.0"
