"""``shlight validate-shaders``: its command-line options."""
from __future__ import annotations


#: Where ``--write-vectors`` alone writes: the current folder, never the installed package
#: (the tracked file, shaders/contract_vectors.json, is updated by naming it).
DEFAULT_VECTORS_OUT = "contract_vectors.json"


def add_arguments(p) -> None:
    from ..verify.harness import DENSE_NORMALS, FLOAT32_TOLERANCE
    p.add_argument("panoramas", nargs="*", metavar="PANORAMA",
                   help="equirect panoramas (.exr, .hdr, ...) for the real-scene cases and the "
                        "pictures (default: the nine real panoramas shipped with shlight)")
    p.add_argument("--out", default="out/validate",
                   help="folder for the PNG pictures and report.json (default: out/validate)")
    p.add_argument("--no-pictures", action="store_true", help="skip the PNG pictures")
    p.add_argument("--no-hlsl", action="store_true", help="check the GLSL path only")
    p.add_argument("--require-hlsl", action="store_true",
                   help="fail (exit 1) when the HLSL path cannot run, instead of skipping it")
    p.add_argument("--normals", type=int, default=DENSE_NORMALS,
                   help=f"dense normals per case (default {DENSE_NORMALS})")
    p.add_argument("--tolerance", type=float, default=FLOAT32_TOLERANCE,
                   help="max |E_gpu - E_cpu| / (|n|^T|M||n|) (default 32 float32 roundoffs "
                        f"= {FLOAT32_TOLERANCE:.2e}); the reflection checks scale their own "
                        "tolerance, (32 + 4 x cube size) roundoffs, by the same factor")
    p.add_argument("--write-vectors", nargs="?", const=DEFAULT_VECTORS_OUT, default=None,
                   metavar="PATH", help="write the contract test vectors, then check them "
                                        f"(default path: ./{DEFAULT_VECTORS_OUT}; the "
                                        "repository's own: shaders/contract_vectors.json)")
    p.add_argument("--vectors", default=None, metavar="PATH",
                   help="contract vectors to check on the GPU (default: "
                        "shaders/contract_vectors.json if present)")


#: The most dense normals per case (--normals): 4M normals, ~100 MB per array.
MAX_NORMALS = 1 << 22


def check_arguments(args):
    """Every option checked before any work starts (no OpenGL context, nothing written);
    the checked ``--write-vectors`` output (:func:`.outputs.output_file`), or None."""
    import json
    import math
    import os
    from ..core.errors import InputError
    from .options import refuse_unused_options
    refuse_unused_options(args)         # --no-hlsl with --require-hlsl
    if not 1 <= args.normals <= MAX_NORMALS:
        raise InputError(f"--normals must be between 1 and {MAX_NORMALS}, got {args.normals}")
    if not (math.isfinite(args.tolerance) and args.tolerance > 0):
        raise InputError(f"--tolerance must be a finite number above 0, got {args.tolerance:g}")
    from .outputs import output_file, output_folder
    output_folder(args.out, holds="the pictures and report.json")
    vectors = None
    if args.write_vectors:
        inputs = [(p, "an input panorama") for p in args.panoramas]
        if args.vectors:
            inputs.append((args.vectors, "the --vectors file"))
        vectors = output_file(args.write_vectors, option="--write-vectors", inputs=inputs,
                              product="contract vectors", extension=".json")
        if not args.write_vectors.endswith(".json"):  # `--write-vectors pano.exr` is a slip
            raise InputError(f"--write-vectors {args.write_vectors}: the vectors file must end "
                             "in .json (put panoramas before --write-vectors)")
    if args.panoramas:          # the user's own files: unreadable ones refused before work
        from ..core.radiometry.images import read_image
        for path in args.panoramas:
            read_image(path)
    if args.vectors:
        if not os.path.isfile(args.vectors):
            raise InputError(f"no such vectors file: {args.vectors}")
        try:
            with open(args.vectors, encoding="utf-8") as f:
                doc = json.load(f)
            ok = isinstance(doc, dict) and isinstance(doc.get("cases"), list) and all(
                isinstance(c, dict) and "name" in c for c in doc["cases"])
        except (OSError, ValueError):
            ok = False
        if not ok:
            raise InputError(f"--vectors {args.vectors} is not a contract vectors file (write "
                             "one with --write-vectors)")
    return vectors


def run(args) -> int:
    from ..verify import lights, reflections
    from ..verify.harness import run as run_validation
    vectors = check_arguments(args)
    if vectors is not None:     # written whole here, then checked by the harness as --vectors
        import argparse
        from pathlib import Path
        from ..verify import contract
        with vectors.writing() as tmp:
            contract.write_contract_vectors(Path(tmp))
        print(f"wrote {args.write_vectors}")
        args = argparse.Namespace(**{**vars(args), "write_vectors": None,
                                     "vectors": args.vectors or args.write_vectors})
    return run_validation(args, extensions=(lights, reflections))
