"""A probe's live reflection cube (docs/contract.md §12, "Transport").

* :mod:`.cube`: the cube's worker thread, fed with the frames the probe already decoded,
  and its encodings;
* :mod:`.ktx2`: the KTX 2.0 writer (RGBA16F cube with mips).

May import: :mod:`provider.core`, :mod:`provider.live.wire`.
"""
