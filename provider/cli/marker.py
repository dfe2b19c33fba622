"""``shlight marker``: the printable registration marker as a PNG that prints to size."""
from __future__ import annotations

import struct
import zlib

from ..core.errors import InputError
from .options import finite_float


def add_arguments(p) -> None:
    p.description = ("Write a registration marker to print (docs/contract.md §13): the pattern, "
                     "a white quiet zone and its size under it. Print at 100 % (no 'fit to "
                     "page') and measure the black square: pass that to --marker-size.")
    p.add_argument("marker", metavar="SPEC", help="aruco:DICT_4X4_50:7, or qr:TEXT")
    p.add_argument("--size", type=finite_float, default=0.2, metavar="METRES",
                   help="side of the printed square (ArUco: black border edge to edge; "
                        "QR: the symbol without its quiet zone); default 0.2")
    p.add_argument("--dpi", type=finite_float, default=300.0, help="print resolution (default 300)")
    p.add_argument("-o", "--output", required=True, metavar="FILE.png",
                   help="PNG to write ('-': standard output)")


def png_with_dpi(gray, dpi: float) -> bytes:
    """A grey 8-bit PNG whose pHYs chunk says ``dpi``, so that it prints to size."""
    import cv2
    ok, buf = cv2.imencode(".png", gray)
    if not ok:  # pragma: no cover - OpenCV always encodes a uint8 array
        raise InputError("cannot encode the marker as PNG")
    data = buf.tobytes()
    ppm = round(dpi / 0.0254)
    body = b"pHYs" + struct.pack(">IIB", ppm, ppm, 1)
    chunk = struct.pack(">I", 9) + body + struct.pack(">I", zlib.crc32(body) & 0xFFFFFFFF)
    at = 8 + 8 + 13 + 4          # signature, IHDR length+type, IHDR data, CRC
    return data[:at] + chunk + data[at:]


def run(args) -> int:
    import sys
    from ..core.registration.marker_detect import parse_marker
    from ..core.registration.marker_print import printable_marker, printed_side_m
    from .outputs import output_file
    out = output_file(args.output, product="marker", stdout=True)
    if not out.stdout and not args.output.lower().endswith(".png"):
        raise InputError(f"-o {args.output}: write a .png (it carries its print resolution)")
    spec = parse_marker(args.marker)
    page = printable_marker(spec, args.size, args.dpi)
    out.write(png_with_dpi(page, args.dpi))
    side = printed_side_m(spec, args.size, args.dpi)
    where = "standard output" if out.stdout else args.output
    print(f"shlight marker: wrote {where}: {spec}, side {side * 1000:.1f} mm at "
          f"{args.dpi:g} dpi; register with --marker {spec} --marker-size {side:.4f}",
          file=sys.stderr)
    w_mm, h_mm = (n / args.dpi * 25.4 for n in page.shape[::-1])
    if min(w_mm, h_mm) > 210 or max(w_mm, h_mm) > 297:
        print(f"shlight marker: note: the page is {w_mm:.0f} x {h_mm:.0f} mm, larger than A4: "
              "print on A3, or pass a smaller --size", file=sys.stderr)
    return 0
