"""One pass over a frame that feeds every product it decodes for (no I/O).

A frame is decoded once, band by band while each band is in cache, and each product that
reads it is a *sink* fed by that one traversal (as Filament's ``CubemapUtils::process``
keeps one traversal and lets each product be a small reducer):

* :mod:`.sinks`: the protocol a product's sink keeps (``start`` / ``band`` / ``whole`` /
  ``finish``), :class:`~.sinks.Sinks` (the sinks registered for one frame, read by name),
  and the linear frames kept whole for a later reader;
* :mod:`.traversal`: :class:`~.traversal.FramePass` and its decode strategies: integer
  frames through the table (or only the column spans a projection sees), float frames
  through the clean-up, and the fast path's block means; a product may add a strategy of
  its own that feeds some sinks inside one fused kernel (SH9's lens fold does).

The sinks live with the products that own them (:mod:`provider.core.sh9`,
:mod:`provider.core.lights`, :mod:`provider.core.reflections`).

May import: :mod:`provider.core.radiometry` (the decode, the clean-up, block means) and
:mod:`provider.core.errors`. Not geometry, not any product.
"""
