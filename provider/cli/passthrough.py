"""``shlight passthrough``: a headset camera's response, exposures and white balance from
its pose-tagged views against the sphere (docs/passthrough.md)."""
from __future__ import annotations

import json


def add_arguments(p) -> None:
    p.description = ("Fit a video see-through headset's passthrough camera against the "
                     "360° sphere: its response per channel (camera.json), and each view's "
                     "exposure, white balance and EV100, from the views' nerfstudio "
                     "transforms.json (poses in the sphere's frame, docs/contract.md §1, or "
                     "brought there by --registration). "
                     "Prints JSON (docs/contract.md §15).")
    p.add_argument("views", metavar="VIEWS/transforms.json",
                   help="nerfstudio transforms.json (or its folder): camera_model PINHOLE or "
                        "OPENCV, fl_x fl_y cx cy w h, frames[].file_path, "
                        "frames[].transform_matrix (camera-to-world, OpenGL axes); optional "
                        "time, exposure_s, gain or iso, cct_k per frame")
    p.add_argument("--sphere", required=True, metavar="PANO[@SECONDS]",
                   help="the 360° camera's panorama of the same room (equirect unless "
                        "--sphere-projection): an HDR file (.exr, .hdr) in its own units, or "
                        "an 8/16-bit frame decoded by --sphere-camera (sRGB without it), per "
                        "second of exposure with @SECONDS, as compute reads it")
    p.add_argument("--sphere-projection", default="equirect",
                   choices=["equirect", "fisheye", "dual-fisheye", "cubemap"],
                   help="the sphere's geometry with its default options (docs/contract.md "
                        "§1: a fisheye looking up, 180°; a Theta S dual fisheye; a 6:1 cube "
                        "strip); default equirect. What it does not see is not compared")
    p.add_argument("--sphere-camera", default=None, metavar="CAMERA.json",
                   help="the 360° camera's response (shlight calibrate-response) for an 8/16-"
                        "bit --sphere")
    p.add_argument("--camera-out", default=None, metavar="CAMERA.json",
                   help="also write the headset camera's fitted response as camera.json")
    p.add_argument("--sigma-deg", type=float, default=1.0, metavar="DEG",
                   help="the pose error the fit tolerates: the sphere and views are blurred "
                        "by this angle (default 1)")
    p.add_argument("--registration", default=None, metavar="FILE.json",
                   help="where the headset's world is not the sphere's: a JSON object with "
                        "world_to_sphere (9 numbers, row-major), or shlight register's output "
                        "with marker_in_world added (the same marker's rotation in the "
                        "headset's world, from its tracker; docs/contract.md §13)")
    p.add_argument("--refine-deg", type=float, default=3.0, metavar="DEG",
                   help="search each view's pose within this angle for the turn that fits "
                        "the sphere best (default 3; 0: trust the poses)")
    p.add_argument("--pretty", action="store_true", help="indent the JSON")


def read_sphere(args):
    """The sphere as linear radiance (H, W, 3), in the units ``compute`` reports for it."""
    import numpy as np
    from ..core.errors import InputError
    from .feedback import say
    from .frames import read_exposed_frames
    images, exposures, _ = read_exposed_frames([args.sphere], need_times=False)
    img, t = images[0], exposures[0].exposure_s
    iso, f_number = exposures[0].iso, exposures[0].f_number
    if img.ndim != 3 or img.shape[2] < 3:
        raise InputError(f"--sphere {args.sphere}: expected an RGB panorama, got shape "
                         f"{img.shape}")
    img = img[..., :3]
    if img.dtype.kind == "f":
        if args.sphere_camera:
            raise InputError("--sphere-camera decodes an 8/16-bit --sphere; this one is "
                             "already linear (float)")
        out = img.astype(np.float64)
    else:
        from ..core.radiometry.response import CameraResponse
        if args.sphere_camera:
            from ..live.probe.camerafile import load_camera
            response = load_camera(args.sphere_camera)
        else:
            say("passthrough", "warning", f"--sphere {args.sphere} is {img.dtype} codes "
                "and no --sphere-camera was given: decoded as sRGB, which is not the light "
                "of most cameras (shlight calibrate-response)")
            response = CameraResponse.srgb(8 if img.dtype == np.uint8 else 16)
        bits = 8 if img.dtype == np.uint8 else 16
        if response.bits != bits:
            response = response.to_bits(bits)
        # as compute: radiance per (t · ISO/100), and cd/m² with an absolute camera
        gain = iso / 100.0 if iso and t is not None else 1.0
        out = response.linearise(img, t or 1.0, gain).astype(np.float64)
        from ..core.radiometry.photometry import absolute_factor
        factor = absolute_factor(response, f_number) if t is not None else None
        if factor is not None:
            out *= factor
        elif response.params.get("absolute"):
            say("passthrough", "note", "the sphere's camera has an absolute scale but the "
                "frame's exposure time is unknown (no @SECONDS, no EXIF ExposureTime): "
                "units stay relative")
        return out
    return out / t if t is not None else out


def sphere_as_equirect(args, sphere):
    """The sphere resampled to equirect from ``--sphere-projection`` (one line if its size
    does not fit that projection)."""
    if args.sphere_projection == "equirect":
        return sphere
    from ..core.errors import InputError
    from ..core.geometry.checks import ProjectionError
    from ..core.geometry.projections import make_projection
    from ..core.passthrough.sphere import to_equirect
    h, w = sphere.shape[:2]
    try:
        projection = make_projection(args.sphere_projection, w, h)
    except ProjectionError as exc:
        raise InputError(f"--sphere {args.sphere}: {exc}") from None
    return to_equirect(sphere, projection).astype("float64")


def run(args) -> int:
    import math
    from ..core.errors import InputError
    from ..core.passthrough import PassthroughFit, read_transforms
    from ..core.passthrough.views import read_view_image
    from .feedback import say, write_output
    if not (math.isfinite(args.sigma_deg) and 0 <= args.sigma_deg <= 10):
        raise InputError(f"--sigma-deg must be between 0 and 10 degrees, got {args.sigma_deg}")
    views = read_transforms(args.views)          # every record checked before any work
    if args.registration:
        from ..core.passthrough.views import read_json, registered, registration_rotation
        views = registered(views, registration_rotation(read_json(args.registration),
                                                        args.registration))
    sphere = sphere_as_equirect(args, read_sphere(args))
    if not (math.isfinite(args.refine_deg) and 0 <= args.refine_deg <= 10):
        raise InputError(f"--refine-deg must be between 0 and 10 degrees, got "
                         f"{args.refine_deg}")
    fit = PassthroughFit(sphere, sigma_deg=args.sigma_deg, refine_deg=args.refine_deg)
    for view in views:
        fit.add_view(view, read_view_image(view))
    result = fit.solve()
    told = sum(v.exposure_s is not None for v in views)
    if result.response.params.get("metadata_exposures"):
        say("passthrough", "note", "every view says its exposure: the fit uses it")
    elif told:
        say("passthrough", "warning", f"{told} of {len(views)} views say their exposure_s: "
            "it is used only when every view does (fitted from the sphere instead)")
    unfit = [v.file_path for v, ok in zip(views, result.fitted) if not ok]
    if unfit:
        say("passthrough", "warning", f"{len(unfit)} view(s) had too few usable pixels "
            f"(clipped, black, or where the sphere sees nothing): their exposure is the "
            f"others' median ({', '.join(unfit[:3])}{' ...' if len(unfit) > 3 else ''})")
    out = result.to_json()
    if args.camera_out:
        from ..live.probe.camerafile import save_camera
        save_camera(result.response, args.camera_out)
    write_output(json.dumps(out, indent=2 if args.pretty else None, allow_nan=False))
    return 0
