"""The dicts cpvs returns, as typing.TypedDict classes for type checkers (cpvs.read_info, ShadowFile.info and
ShadowFile.lights give plain dicts of these shapes)."""
from typing import Any, Literal, Optional, Sequence, TypedDict, Union


class ViewInfo(TypedDict):
    resolution: int
    face: Optional[int]
    projection: Literal["orthographic", "perspective"]


class LightInfo(TypedDict):
    name: str
    index: int
    type: Literal["directional", "spot", "point"]
    color: tuple[float, float, float]
    intensity: float
    range: Optional[float]
    position: Optional[tuple[float, float, float]]
    direction: Optional[tuple[float, float, float]]
    inner_cone_angle: Optional[float]
    outer_cone_angle: Optional[float]
    views: list[ViewInfo]
    resolution: int


class FileInfo(TypedDict):
    path: str
    format_version: str
    bytes: int
    settings: Any
    input_hash: Optional[str]
    lights: list[LightInfo]


# What ShadowFile.lookup's light= takes: an index, a name, a list of those, or None (the file's only light).
LightSelector = Union[int, str, Sequence[Union[int, str]], None]
