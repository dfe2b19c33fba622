"""Radiometry: from code values to light (no sockets, no threads).

* :mod:`.images`: reading image files into the frame contract (RGB, uint8/uint16/float32),
  and JPEG frames (``decode_jpeg``: simplejpeg, its words returned, not printed);
* :mod:`.image_size`: the size a file's header declares, and the pixel budget checked on
  it before decoding;
* :mod:`.decode`: :class:`~provider.core.radiometry.decode.FrameDecoder`, a frame decoded
  once for every product (transfer function or camera response as a table, exposure);
* :mod:`.float_clean`: NaN, ±inf and negative samples of float frames, counted;
* :mod:`.response`, :mod:`.response_fit`: a camera's inverse response and its calibration;
* :mod:`.bracket`: brackets of one view merged into scene-referred light;
* :mod:`.exif`: a still's own exposure (ExposureTime, FNumber, ISO) from its EXIF;
* :mod:`.photometry`: absolute units (cd/m², lux, EV100) from a frame's exposure;
* :mod:`.colour_temperature`: CCT and Duv of linear Rec. 709 light;
* :mod:`.checker`: a camera's white balance and 3×3 colour matrix from a ColorChecker
  (OpenCV's mcc and ccm).

May import: numpy, OpenCV, OpenEXR, simplejpeg, :mod:`provider.core.errors`. Nothing of geometry or the
products.
"""
