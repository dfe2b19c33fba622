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
    p.add_argument("--extended-out", default=None, metavar="OUT.exr",
                   help="also write the sphere extended by the views (an equirect OpenEXR in "
                        "the sphere's units): where the 360° camera sees nothing (non-finite "
                        "or black pixels, --sphere-mask, --nadir-cap-deg) the views' light, "
                        "brought to the sphere's units by the fit; the JSON's 'extended' says "
                        "the solid angle gained (docs/passthrough.md)")
    p.add_argument("--sphere-mask", default=None, metavar="MASK",
                   help="an image of the sphere's size and projection, nonzero where the 360° "
                        "camera sees nothing (its mount): not compared, and filled by "
                        "--extended-out")
    p.add_argument("--nadir-cap-deg", type=float, default=0.0, metavar="DEG",
                   help="the cap within DEG of straight down (the tripod) is taken as unseen "
                        "(default 0: none)")
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
    import numpy as np
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
    if not (math.isfinite(args.refine_deg) and 0 <= args.refine_deg <= 10):
        raise InputError(f"--refine-deg must be between 0 and 10 degrees, got "
                         f"{args.refine_deg}")
    if not (math.isfinite(args.nadir_cap_deg) and 0 <= args.nadir_cap_deg <= 180):
        raise InputError(f"--nadir-cap-deg must be between 0 and 180 degrees, got "
                         f"{args.nadir_cap_deg}")
    out_file = extended_output(args)             # checked before any work
    raw = read_sphere(args)
    sphere = sphere_as_equirect(args, raw)
    holes = sphere_holes_of(args, sphere, raw.shape)
    if holes.all():
        raise InputError(f"--sphere {args.sphere}: the sphere sees nothing (every pixel is "
                         "masked, non-finite or black)")
    fitted_sphere = np.where(holes[..., None], 0.0, np.nan_to_num(sphere))
    fit = PassthroughFit(fitted_sphere, sigma_deg=args.sigma_deg, refine_deg=args.refine_deg)
    images = []
    for view in views:
        image = read_view_image(view)
        fit.add_view(view, image)
        if out_file is not None:      # kept for the extension only
            images.append(image)
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
    if out_file is not None:
        out["extended"] = write_extended(args, out_file, sphere, holes, result, views, images)
    if args.camera_out:
        from ..live.probe.camerafile import save_camera
        save_camera(result.response, args.camera_out)
    write_output(json.dumps(out, indent=2 if args.pretty else None, allow_nan=False))
    return 0


def extended_output(args):
    """``--extended-out``'s :class:`~.outputs.OutputFile`, checked before any work."""
    if not args.extended_out:
        return None
    from .frames import parse_frame
    from .outputs import output_file
    inputs = [(parse_frame(args.sphere)[0], "the --sphere panorama"),
              (args.sphere_mask, "the --sphere-mask image"), (args.views, "the views")]
    return output_file(args.extended_out, option="--extended-out", inputs=inputs,
                       product="extended sphere", extension=".exr")


def sphere_holes_of(args, sphere, raw_shape):
    """Where the 360° camera sees nothing (:func:`~provider.core.passthrough.extend.
    sphere_holes`), with ``--sphere-mask`` read in the sphere's projection and resampled
    with it."""
    import numpy as np
    from ..core.errors import InputError
    from ..core.passthrough.extend import sphere_holes
    mask = None
    if args.sphere_mask:
        from ..core.radiometry.images import read_image
        raw = np.asarray(read_image(args.sphere_mask), np.float32)
        raw = raw.reshape(raw.shape[0], raw.shape[1], -1)
        if raw.shape[:2] != tuple(raw_shape[:2]):
            raise InputError(f"--sphere-mask {args.sphere_mask} is {raw.shape[1]}×"
                             f"{raw.shape[0]}; the sphere is {raw_shape[1]}×{raw_shape[0]} "
                             "(the mask is in the sphere's own projection)")
        if args.sphere_projection != "equirect":
            from ..core.passthrough.sphere import to_equirect
            from ..core.geometry.projections import make_projection
            projection = make_projection(args.sphere_projection, raw.shape[1], raw.shape[0])
            raw = to_equirect(np.repeat((raw != 0).any(-1, keepdims=True), 3, -1)
                              .astype(np.float32), projection)
        mask = (raw >= 0.5).any(-1) if args.sphere_projection != "equirect" else \
            (raw != 0).any(-1)
    return sphere_holes(sphere, mask, args.nadir_cap_deg)


def write_extended(args, out_file, sphere, holes, result, views, images) -> dict:
    """The sphere filled from the views, written as OpenEXR; what it gained (sr). Views
    the fit could not fit (they look where the sphere sees nothing), or whose fit their
    overlaps contradict, are brought to its units by their overlaps with the others."""
    import math
    from ..core.passthrough.extend import fill_sphere, splat_views
    from ..core.passthrough.overlaps import anchored_to_fit
    from .feedback import say
    exposure, wb, use, swapped = anchored_to_fit(result, views, images)
    coverage = splat_views(views, images, result.response.table, exposure, wb,
                           result.vignetting, height=sphere.shape[0], use=use)
    filled = fill_sphere(sphere, holes, coverage)
    write_exr(out_file, filled.sphere)
    seen = 4 * math.pi - filled.holes_sr
    if filled.holes_sr and not filled.gained_sr:
        say("passthrough", "warning", "no view looked where the 360° camera sees nothing: "
            f"{args.extended_out} is the sphere as it was (holes black)")
    if filled.clipped_sr:
        say("passthrough", "warning", f"{filled.clipped_sr:.3g} sr of what the views filled "
            "was clipped in every view that saw it: filled at the clip level, a lower bound "
            "(a headset cannot measure a light it clips in every view)")
    return {"file": args.extended_out, "holes_sr": filled.holes_sr,
            "gained_sr": filled.gained_sr, "clipped_sr": filled.clipped_sr,
            "coverage_sr": seen + filled.gained_sr, "sphere_coverage_sr": seen,
            "views_coverage_sr": coverage.coverage_sr,
            "views_from_overlaps": int(swapped.sum())}


def write_exr(out_file, image) -> None:
    """``image`` (H, W, 3) float32 as a scan-line OpenEXR (ZIP), written whole then renamed
    over the target (:meth:`~.outputs.OutputFile.writing`)."""
    import numpy as np
    import OpenEXR
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with out_file.writing() as tmp:
        with OpenEXR.File(header, {"RGB": np.ascontiguousarray(image, np.float32)}) as f:
            f.write(tmp)


# -- shlight compute VIEWS/transforms.json: the views alone ----------------------------------

#: The panorama the views are fused into (rows): 0.7° a pixel, finer than SH9 needs.
VIEWS_HEIGHT = 256
HEADSET_CLIPS = ("a headset cannot measure a light it clips in every view (an auto "
                 "exposure holds the mean at mid-grey: lamps, windows, the sun clip): "
                 "clipped_light_fraction counts them at the clip level, a lower bound; a "
                 "360° camera (shlight passthrough --sphere) measures them")


def is_views_input(texts) -> bool:
    """Whether ``compute``'s inputs name a ``transforms.json`` (or a folder holding one)."""
    import os
    return any(t.lower().endswith(".json") or os.path.isfile(os.path.join(t, "transforms.json"))
               for t in texts)


def compute_views(args) -> dict:
    """``shlight compute VIEWS/transforms.json``: the views alone, fused into an equirect
    panorama (their exposures and white balance from their overlaps,
    :mod:`~provider.core.passthrough.overlaps`) and projected on SH9 as compute projects a
    frame; the wire message with ``coverage_sr``, ``clipped_light_fraction`` (a lower
    bound) and ``warnings``."""
    import math
    import os
    import numpy as np
    from ..core.errors import InputError
    from ..core.passthrough import read_transforms
    from ..core.passthrough.extend import splat_views
    from ..core.passthrough.overlaps import relative_exposures
    from ..core.passthrough.views import read_view_image
    from ..core.radiometry.response import CameraResponse
    from ..core.sh9.engine import SH9Projector
    from ..live.wire.message import coefficient_message
    from .feedback import say
    from .options import engine_options
    from .options import check_meter_arguments
    command = "compute"
    check_meter_arguments(args)
    if len(args.image) > 1:
        raise InputError("a transforms.json is computed alone: give it as the only input "
                         f"(got {len(args.image)})")
    if args.projection not in ("equirect", "auto"):
        raise InputError(f"--projection {args.projection}: a transforms.json's views are "
                         "fused into an equirect panorama; leave --projection out")
    if getattr(args, "lux", None) is not None:
        raise InputError("--lux closes a frame's clipped light with a meter read with it; "
                         "a transforms.json's views have none: leave --lux out")
    args.projection = "equirect"
    options = engine_options(args)
    response = options.pop("response", None)
    views = read_transforms(args.image[0])
    images = [read_view_image(v, args.max_frame_pixels) for v in views]
    warnings = []
    if response is None:
        warnings.append("no --camera: the views are decoded as sRGB, which is not most "
                        "headsets' curve (shlight passthrough --camera-out writes the "
                        "headset's)")
        response = CameraResponse.srgb(8)
    elif response.bits != 8:
        response = response.to_bits(8)
    vig = response.params.get("vignetting") or {}
    vignetting = (float(vig.get("v1", 0.0)), float(vig.get("v2", 0.0)))
    overlaps = relative_exposures(views, images, response.table, vignetting)
    lone = int((~overlaps.connected).sum())
    if lone and len(views) > 1:
        warnings.append(f"{lone} of {len(views)} views share no directions with the others: "
                        "left out")
    coverage = splat_views(views, images, response.table, overlaps.exposure,
                           overlaps.wb_gains, vignetting, height=VIEWS_HEIGHT,
                           use=overlaps.connected if len(views) > 1 else None)
    pano = coverage.lower_bound().astype(np.float32)
    if not pano.any():
        raise InputError(f"{args.image[0]}: the views measured nothing (every pixel black, or "
                         "no two views overlap)")
    projector = SH9Projector(pano.shape[1], pano.shape[0], "equirect", error_estimate=True,
                             **options)
    result = projector.project(pano)
    coverage_sr = coverage.coverage_sr
    clipped = coverage.clipped_light_fraction()
    result.stats.update(coverage_sr=coverage_sr, clipped_light_fraction=clipped,
                        clipped_fraction=float(coverage.clipped.mean()),
                        radiometry="srgb-assumed" if response.method == "srgb" else "calibrated",
                        response=response.method)
    if coverage_sr < 4 * math.pi * 0.999:
        warnings.append(f"the views saw {coverage_sr:.2f} of 4π = 12.57 sr "
                        f"({coverage_sr / (4 * math.pi):.0%}): what no view saw is black in "
                        "the SH9 (a lower bound of the light)")
    if clipped > 0:
        warnings.append(f"{clipped:.0%} of the light seen was clipped in every view that saw "
                        "it; " + HEADSET_CLIPS)
    else:
        warnings.append(HEADSET_CLIPS)
    for line in warnings:
        say(command, "warning", line)
    units = ("per second of exposure per unit gain (every view's exposure_s)"
             if overlaps.metadata else "relative: the views' mean exposure renders 0.18 as "
             "the curve's mid-grey")
    return coefficient_message(
        result, probe=args.probe, seq=0, time=os.path.getmtime(args.image[0]),
        projection="views", views=len(views),
        views_used=int(overlaps.connected.sum()) if len(views) > 1 else 1,
        view_pairs=overlaps.pairs, radiance_scale=units, warnings=" | ".join(warnings))
