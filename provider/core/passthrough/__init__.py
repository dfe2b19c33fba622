"""The headset's passthrough camera against the sphere (no I/O but reading the views).

A video see-through headset shows the room through a camera that auto-exposes,
white-balances and tone-maps every frame. Its pose-tagged views (nerfstudio's
``transforms.json``, :mod:`.views`), compared with the calibrated 360° sphere in the same
directions, tell its response, each view's exposure and its white balance (:mod:`.fit`):
what a hologram must go through to look like its real replica in passthrough
(docs/passthrough.md).

:mod:`.sphere` resamples a sphere in any projection to the equirect the fit samples;
:mod:`.display` is the 256-entry display lookup every consumer renders a hologram through.

It may import errors, radiometry and geometry (pyproject.toml's contracts); nothing of the products
(sh9, lights, reflections) and they nothing of it.
"""
from .display import DisplayLookup, display_codes, display_lookup
from .fit import PassthroughFit, PassthroughResult, fit_views
from .views import PassthroughView, read_transforms

__all__ = ["DisplayLookup", "PassthroughFit", "PassthroughResult", "PassthroughView",
           "display_codes", "display_lookup", "fit_views", "read_transforms"]
