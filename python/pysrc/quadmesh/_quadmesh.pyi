from typing import Any, Dict, Optional

import numpy as np

NONE: int

class QuadmeshError(ValueError): ...

def _mesh(
    points: np.ndarray,
    segments: Optional[np.ndarray] = ...,
    segment_markers: Optional[np.ndarray] = ...,
    holes: Optional[np.ndarray] = ...,
    regions: Optional[np.ndarray] = ...,
    *,
    min_angle: float = ...,
    max_area: Optional[float] = ...,
    max_vertices: Optional[int] = ...,
    mode: str = ...,
    convex_hull: bool = ...,
    no_boundary_steiner: bool = ...,
    split_crossings: bool = ...,
    threads: Optional[int] = ...,
    edges: bool = ...,
) -> Dict[str, Any]: ...

class _DynamicMesh:
    def __init__(self, points: np.ndarray, domain: tuple[float, float, float, float]) -> None: ...
    def __len__(self) -> int: ...
    def insert(self, x: float, y: float) -> int: ...
    def delete(self, id: int) -> None: ...
    def move_to(self, id: int, x: float, y: float) -> None: ...
    def move_all(self, ids: np.ndarray, displacements: np.ndarray) -> None: ...
    def live_ids(self) -> np.ndarray: ...
    def mesh(self) -> Dict[str, Any]: ...
