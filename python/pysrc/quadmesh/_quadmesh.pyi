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
