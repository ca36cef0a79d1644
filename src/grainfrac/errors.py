"""Typed exceptions. Library code raises these; only the CLI turns them into exit codes."""


class GrainfracError(Exception):
    """Base class of every error grainfrac raises on purpose."""


class ConfigError(GrainfracError, ValueError):
    """A recipe, specimen or scenario is invalid.

    The message is one line that names the offending field and the allowed range,
    e.g. ``config error at minerals.0.youngs_modulus_GPa: must be > 0 (got -3.0)``.
    """

    def __init__(self, field: str, message: str):
        self.field = field
        self.message = message
        super().__init__(f"config error at {field}: {message}")


class GeometryError(GrainfracError):
    """A specimen could not be tessellated or meshed as requested."""


class CheckpointError(GrainfracError):
    """A checkpoint cannot be read: an old format, another format version, or damaged."""
