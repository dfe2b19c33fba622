"""``shlight validate-shaders``: its command-line options."""
from __future__ import annotations


def add_arguments(p) -> None:
    from ..verify.contract import VECTORS_PATH
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
    p.add_argument("--write-vectors", nargs="?", const=str(VECTORS_PATH), default=None,
                   metavar="PATH", help="write the contract test vectors (default path: "
                                        "shaders/contract_vectors.json), then check them")
    p.add_argument("--vectors", default=None, metavar="PATH",
                   help="contract vectors to check on the GPU (default: "
                        "shaders/contract_vectors.json if present)")


def run(args) -> int:
    from ..verify import lights, reflections
    from ..verify.harness import run as run_validation
    return run_validation(args, extensions=(lights, reflections))
