"""Typed exceptions. Library code raises these; only the CLI turns them into exit codes."""


class GrainfracError(Exception):
    """Base class of every error grainfrac raises on purpose."""


class ConfigError(GrainfracError, ValueError):
    """A recipe, specimen or scenario is invalid.

    The message is one line that names the offending field and the allowed range,
    e.g. ``config error at minerals.0.youngs_modulus_GPa: must be > 0 (got -3.0)``.

    Several problems found at once (:attr:`problems`, each ``(field, message)``)
    read one line each; ``field`` and ``message`` are the first.
    """

    def __init__(self, field: str, message: str,
                 more: list[tuple[str, str]] | None = None):
        self.field = field
        self.message = message
        self.problems = [(field, message), *(more or [])]
        super().__init__("\n".join(f"config error at {f}: {m}" for f, m in self.problems))

    def __reduce__(self):
        # Rebuilt from its parts in another process (a pool worker's error reaches the
        # parent pickled); the default would call __init__ with the message alone.
        return (type(self), (self.field, self.message, self.problems[1:]))


class GeometryError(GrainfracError):
    """A specimen could not be tessellated or meshed as requested."""


class CheckpointError(GrainfracError):
    """A checkpoint cannot be read: an old format, another format version, or damaged."""
