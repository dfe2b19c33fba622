"""``shlight locate-ball``: where the mirror ball is in a frame, as JSON."""
from __future__ import annotations


def add_arguments(p) -> None:
    p.add_argument("image", help="a photograph or webcam frame of a mirror ball (.png, .jpg, "
                                 ".exr, ...)")
    p.add_argument("--min-radius", type=float, default=0.05, metavar="FRACTION",
                   help="smallest ball radius sought, as a fraction of the frame's smaller "
                        "side (default 0.05)")


def run(args) -> int:
    import json
    from ..core.registration.ball import locate_ball
    from ..core.errors import InputError
    from ..core.radiometry.images import read_image
    from .feedback import say
    from .options import say_fifo_waits
    if not 0 < args.min_radius < 0.55:
        raise InputError(f"--min-radius {args.min_radius:g}: a fraction in (0, 0.55)")
    say_fifo_waits([args.image], "locate-ball")
    image = read_image(args.image)
    # a circle that runs past the frame is refused by locate_ball ("no ball found ...")
    circle = locate_ball(image, min_radius_fraction=args.min_radius)
    if circle.weak:
        say("locate-ball", "warning", circle.weak_note())
    print(json.dumps({**circle.as_dict(), "width": int(image.shape[1]),
                      "height": int(image.shape[0])}))
    return 0
