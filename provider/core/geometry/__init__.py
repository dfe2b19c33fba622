"""Geometry: where each pixel looks and how much of the sphere it sees (no pixels, no I/O).

* :mod:`.sh`: the real SH basis (docs/contract.md §1-2), irradiance, the 4×4 matrices,
  rotation, windowing;
* :mod:`.projections`: per-pixel directions and exact solid angles, one class per
  projection (equirect, fisheye, dual fisheye, cube map), and their SH weights;
* :mod:`.projections_probe`: light-probe projections (mirror ball, angular map, cube cross);
* :mod:`.projections_exr`: OpenEXR's own environment maps (latlong, cube) in its conventions;
* :mod:`.lens_profiles`: fisheye lens curves and the Ricoh Theta profiles (Ricoh's tables);
* :mod:`.lens_calibration`: a lens curve from chessboard photos (cv2.fisheye), lens files;
* :mod:`.radial_fit`: a radially symmetric image's per-pixel weights as radial profiles;
* :mod:`.cubemap`: cube-map texel directions, solid angles and pooling (§12);
* :mod:`.sphere_views`: pinhole views rendered from any projection;
* :mod:`.checks`: :class:`~provider.core.geometry.checks.ProjectionError` and the checks of
  a projection against its frame.

May import: numpy, OpenCV, :mod:`provider.core.errors`. Nothing of radiometry or the products.
"""
