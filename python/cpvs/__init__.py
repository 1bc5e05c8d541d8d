"""cpvs: Compact Precomputed Voxelized Shadows, baked and looked up from Python.

    import cpvs
    report = cpvs.bake("level.glb", "level.cpvs", resolution="8k", cache="bake-cache")
    points, normals = cpvs.sample("level.glb", 100_000, seed=1)
    lit = cpvs.open("level.cpvs").lookup(points, normals, light="sun")
    image = cpvs.preview("level.glb", "level.cpvs", size=(960, 540))  # (540, 960, 3) uint8

See docs/python.md for every function, its errors and a worked example (examples/python/)."""

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
