"""Light at any point of the room from several probes at known positions (no I/O).

* :mod:`.parallax`: with the room's box, each probe's panorama re-projected through the
  room to the point (:func:`~provider.core.probes.parallax.reproject`), then projected like
  any frame;
* :mod:`.mesh`: the room as a triangle mesh (trimesh: OBJ, PLY, glTF), whose walls also
  hide wall points from probes;
* :mod:`.tetrahedra`: without it, the probes' SH9 blended as the engines blend their own
  (Delaunay tetrahedra inside the probes' hull, inverse distance outside).

docs/probes.md measures them. May import errors and geometry (pyproject.toml's contracts),
and trimesh for a mesh; nothing of the products, and they nothing of it.
"""
from .parallax import Box, parse_room, reproject
from .tetrahedra import Tetrahedra, blend, inverse_distance, nearest

__all__ = ["Box", "Tetrahedra", "blend", "inverse_distance", "nearest", "parse_room",
           "reproject"]
