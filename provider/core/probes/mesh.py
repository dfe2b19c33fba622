"""A room as a triangle mesh (OBJ, PLY, glTF, STL, OFF; read and ray-cast by trimesh):
where a ray from a point leaves the room, and which wall points a probe sees (no other I/O
than reading the file, like an image).

A ray that finds no wall (a hole in the mesh, an open door) is taken to see far away: the
probes' panoramas are read in its own direction there, as without a room. Casting is
trimesh's numpy engine (about 40,000 rays a second against a small room here): a point costs
its rays once and once more per probe, for the occlusion.
"""
from __future__ import annotations

import os

import numpy as np

from ..errors import InputError

#: The file types a room is read from.
MESH_EXTENSIONS = (".obj", ".ply", ".glb", ".gltf", ".stl", ".off")
#: Where a ray that leaves through a hole is taken to end (metres): far, as a sky is.
FAR = 1e4


class MeshRoom:
    """The room's triangles (a ``trimesh.Trimesh``), in the probes' world frame (metres)."""

    def __init__(self, mesh, name: str = "mesh"):
        from trimesh.ray.ray_triangle import RayMeshIntersector
        if len(mesh.faces) == 0:
            raise InputError(f"{name}: the mesh has no triangles")
        self.mesh, self.name = mesh, name
        self._rays = RayMeshIntersector(mesh)
        self.lo, self.hi = np.asarray(mesh.bounds[0]), np.asarray(mesh.bounds[1])

    def _first_hits(self, origins, directions):
        """Distances (N,) to the first triangle along each ray (inf: none), its normals."""
        n = len(directions)
        dist, normals = np.full(n, np.inf), np.zeros((n, 3))
        if n == 0:
            return dist, normals
        locations, rays, tris = self._rays.intersects_location(
            origins, directions, multiple_hits=False)
        if len(rays):
            d = np.einsum("ij,ij->i", locations - origins[rays], directions[rays])
            dist[rays] = d
            normals[rays] = self.mesh.face_normals[tris]
        return dist, normals

    def contains(self, point, margin: float = 0.0) -> bool:
        """Inside the mesh's bounds, with walls around in the six axis directions."""
        p = np.asarray(point, np.float64)
        if not (np.all(p > self.lo + margin) and np.all(p < self.hi - margin)):
            return False
        axes = np.concatenate([np.eye(3), -np.eye(3)])
        dist, _ = self._first_hits(np.tile(p, (6, 1)), axes)
        return bool(np.all(np.isfinite(dist)) and np.all(dist > margin))

    def exits(self, origin, directions):
        """Where rays from ``origin`` meet the room: wall points (N, 3), and the walls'
        normals facing the origin (N, 3); a ray through a hole ends :data:`FAR` away."""
        d = np.asarray(directions, np.float64).reshape(-1, 3)
        o = np.asarray(origin, np.float64)
        dist, normals = self._first_hits(np.tile(o, (len(d), 1)), d)
        hole = ~np.isfinite(dist)
        dist[hole] = FAR
        normals[hole] = -d[hole]
        flip = np.einsum("ij,ij->i", normals, d) > 0
        normals[flip] *= -1
        return o + dist[:, None] * d, normals

    def visible(self, probe, points) -> np.ndarray:
        """Which wall ``points`` (N, 3) the probe at ``probe`` sees (nothing nearer on the
        way; within a millimetre or 0.1 %)."""
        p = np.asarray(probe, np.float64)
        v = np.asarray(points, np.float64) - p
        length = np.linalg.norm(v, axis=1)
        toward = v / np.maximum(length, 1e-12)[:, None]
        dist, _ = self._first_hits(np.tile(p, (len(v), 1)), toward)
        return (dist >= length - np.maximum(1e-3, 1e-3 * length)) | (length >= FAR * 0.99)

    def __str__(self):
        return f"{self.name} ({len(self.mesh.faces)} triangles)"


def read_mesh(path: str) -> MeshRoom:
    """The room in the mesh file ``path``; :class:`InputError` in one line."""
    if not os.path.isfile(path):
        raise InputError(f"no such file: {path}")
    try:
        import trimesh
    except ImportError:
        raise InputError("reading a room's mesh needs trimesh and rtree (pip install "
                         "'shlight[room]')") from None
    try:
        mesh = trimesh.load(path, force="mesh")
    except Exception as exc:  # noqa: BLE001 - any parser's error is the file's, one line
        raise InputError(f"{path}: not a mesh trimesh reads ({type(exc).__name__}: "
                         f"{str(exc)[:120]})") from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise InputError(f"{path}: no triangles in it")
    return MeshRoom(mesh, os.path.basename(path))
