"""``shlight environment IMAGE -o cube.ktx2``: the reflection cube of one image (an HDR cube
map with GGX-prefiltered mips, KTX 2.0 RGBA16F; docs/contract.md §12), with the input
options of ``shlight compute``; a one-line summary on stderr."""
from __future__ import annotations

import os
import sys

from .options import add_budget_argument, add_engine_arguments, add_table_cache_argument


def add_arguments(p) -> None:
    p.description = ("The reflection cube of one panorama or fisheye image: a KTX 2.0 cube "
                     "map (RGBA16F, all mips, GGX-prefiltered; docs/contract.md §12).")
    p.add_argument("image", metavar="IMAGE[@SECONDS]",
                   help="panorama/fisheye image (.exr, .hdr, .png, .jpg, ...); with its "
                        "exposure time, IMAGE@SECONDS: radiance per second of exposure")
    p.add_argument("-o", "--output", required=True, metavar="CUBE.ktx2",
                   help="where to write the KTX2 file ('-': standard output)")
    p.add_argument("--size", type=int, default=32, metavar="N",
                   help="edge of a cube face in texels: a power of two from 8 to 256 "
                        "(default 32)")
    p.add_argument("--probe", default="default", help="probe name in the file's key/value data")
    add_budget_argument(p, 0, "the command fails with one line (exit 2)")
    add_engine_arguments(p)
    add_table_cache_argument(p)


def check_output(output: str, image: str, args=None):
    """The checked output (:func:`.outputs.output_file`: refused in one line where it is a
    device, a FIFO, a folder, in a folder that cannot be written, or the input image or
    another input file by any path or link) and the warning for a name whose extension
    says another format, or None."""
    from .outputs import engine_inputs, frame_inputs, output_file
    inputs = frame_inputs([image], "the input image")
    if args is not None:
        inputs += engine_inputs(args)
    out = output_file(output, inputs=inputs, product="cube", extension=".ktx2", stdout=True)
    ext = os.path.splitext(output)[1]
    if not out.stdout and ext and ext.lower() != ".ktx2":
        return out, (f"-o {output}: the file holds a KTX2 cube map, not what '{ext}' says; "
                     "name it .ktx2")
    return out, None


def run(args) -> int:
    from ..live.reflections.cube import check_size, cube_options, encode_environment
    from .feedback import say
    from .frames import read_frames
    from .options import engine_options, say_fifo_waits, say_frame_warnings
    size = check_size(args.size)
    out, foreign = check_output(args.output, args.image, args)
    options = engine_options(args)
    say_fifo_waits([args.image], "environment")
    images, times, paths = read_frames([args.image], need_times=False,
                                       max_pixels=args.max_frame_pixels)
    if foreign:
        say("environment", "warning", foreign)
    from ..core.reflections.environment import EnvironmentProjector
    image = images[0]
    say_frame_warnings(args, image, "environment")
    projector = EnvironmentProjector(image.shape[1], image.shape[0], args.projection,
                                     size=size, **cube_options(options))
    for warning in getattr(projector, "warnings", ()):
        say("environment", "warning", warning)
    result = projector.project(image, exposure_s=times[0])
    from ..core.options import check_cube_lighting
    from .options import say_nonfinite
    check_cube_lighting(result.mips, options.get("exposure", 1.0), times[0])
    say_nonfinite(args, image, result.stats, "environment")
    from ..live.reflections.ktx2 import beyond_half_float
    over, texels = beyond_half_float(result.mips)
    if over:
        say("environment", "warning",
            f"{over:,} of {texels:,} texels are brighter than half float's 65504 and are "
            "stored as 65504 (lower --exposure to keep them)")
    cube = encode_environment(result, probe=args.probe, seq=0, sh9_seq=None,
                              time_s=os.path.getmtime(paths[0]),
                              exposure=options.get("exposure", 1.0), exposure_s=times[0])
    out.write(cube.ktx2)
    where = "standard output" if args.output == "-" else args.output
    rough = ", ".join(f"{r:g}" for r in cube.roughness)
    print(f"shlight environment: {where}: {cube.size}×{cube.size}×6 cube, "
          f"{len(cube.roughness)} mips (roughness {rough}), RGBA16F KTX2, "
          f"{len(cube.ktx2):,} bytes, {cube.compute_ms:.1f} ms", file=sys.stderr)
    return 0

