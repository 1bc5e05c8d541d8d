"""Typed stubs of the cpvs package: it re-exports the compiled module (cpvs/_cpvs.pyi)."""
from ._cpvs import (  # noqa: F401
    ArgumentError,
    Cancelled,
    Error,
    FormatError,
    LightNotFoundError,
    MemoryBudgetError,
    MissingFileError,
    NotSupportedError,
    OutputError,
    Reference,
    RuntimeFailure,
    ShadowFile,
    __version__,
    bake,
    open,
    preview,
    read_info,
    reference,
    sample,
)

__all__ = [
    "ArgumentError", "Cancelled", "Error", "FormatError", "LightNotFoundError", "MemoryBudgetError",
    "MissingFileError", "NotSupportedError", "OutputError", "Reference", "RuntimeFailure", "ShadowFile",
    "__version__", "bake", "open", "preview", "read_info", "reference", "sample",
]
