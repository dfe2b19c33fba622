"""What the Unity tests share (tests/test_unity*.py): the package's C# sources, the Mono
compiler (mcs) and runtime, the frame flip between the wire and Unity (S3, S4), the live
client's driver (:class:`_LiveClient`: tests/csharp/LiveClient.cs under mono). The compiled
live client and the build folder are fixtures in conftest.py (``build_dir``, ``live_exe``),
built once a session."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent
PKG = ROOT / "unity_package"
CORE = sorted((PKG / "Runtime" / "Core").glob("*.cs"))
RUNTIME = sorted((PKG / "Runtime").glob("*.cs"))
SAMPLES = sorted((PKG / "Samples~").rglob("*.cs"))
STANDIN = ROOT / "tests" / "unity_stubs" / "UnityEngineStandIn.cs"
CSHARP = ROOT / "tests" / "csharp"
#: What the Mono drivers share (reflection calls of Unity's messages, numbers, frames played).
HARNESS = CSHARP / "Harness.cs"
VECTORS = ROOT / "shaders" / "contract_vectors.json"
PACKAGE_NAME = "org.shlight.sh9lighting"

S3 = np.diag([1.0, 1.0, -1.0])
S4 = np.diag([1.0, 1.0, -1.0, 1.0])


# ---- building -------------------------------------------------------------------------------

def _mono_tools():
    mcs, mono = shutil.which("mcs"), shutil.which("mono")
    if not (mcs and mono):
        pytest.skip("Mono is not installed: apt-get install mono-mcs mono-runtime")
    return mcs, mono


def _compile(out: Path, sources, target="exe", defines=()):
    """mcs as the package must pass it (warnings are errors); ``defines`` as Unity or a project
    would define them (UNITY_2023_2_OR_NEWER, SHLIGHT_MRUK)."""
    mcs, _ = _mono_tools()
    cmd = [mcs, "-nologo", "-warnaserror+", "-nowarn:618", f"-target:{target}", f"-out:{out}",
           *[f"-define:{d}" for d in defines], *[str(s) for s in sources]]
    # the whole runtime with the stand-in takes a while beside other work on 2 shared cores
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, f"mcs failed:\n{r.stdout}\n{r.stderr}"
    return out



class _LiveClient:
    """tests/csharp/LiveClient.exe under Mono; its JSON event lines collected by a thread."""

    def __init__(self, exe: Path, *args: str, env: dict | None = None):
        _, mono = _mono_tools()
        self.args = args
        self.proc = subprocess.Popen([mono, str(exe), *args], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, text=True, bufsize=1,
                                     env={**os.environ, **(env or {})})
        self.events: list[dict] = []
        self.log: list[str] = []
        self.cond = threading.Condition()
        self.pumps = [threading.Thread(target=self._pump, args=(stream, fn), daemon=True)
                      for stream, fn in ((self.proc.stdout, self._on_stdout), (self.proc.stderr, self.log.append))]
        for t in self.pumps:
            t.start()

    def _pump(self, stream, fn):
        for line in stream:
            with self.cond:
                fn(line.rstrip("\n"))
                self.cond.notify_all()

    def _on_stdout(self, line: str):
        try:
            self.events.append(json.loads(line))
        except ValueError:
            self.log.append("stdout (not JSON): " + line)

    def describe(self) -> str:
        with self.cond:
            ev = [{k: v for k, v in e.items() if k not in ("matrices", "ambient", "wire_matrices",
                                                             "wire_coefficients")} for e in self.events[-15:]]
            return (f"LiveClient {' '.join(self.args)}\nlast events:\n" + "\n".join(map(json.dumps, ev)) +
                    "\nlog:\n" + "\n".join(self.log[-25:]))

    def wait_for(self, what: str, pred, start: int = 0, timeout: float = 20.0) -> tuple[int, dict]:
        """The first event at index >= start that satisfies pred (fails after the deadline)."""
        deadline = time.monotonic() + timeout
        with self.cond:
            i = start
            while True:
                while i < len(self.events):
                    if pred(self.events[i]):
                        return i, self.events[i]
                    i += 1
                left = deadline - time.monotonic()
                if left <= 0 or not self.pumps[0].is_alive() and i >= len(self.events):
                    break                       # out of time, or the program ended and all is read
                self.cond.wait(min(left, 0.2))
        pytest.fail(f"{what}: not seen within {timeout:g} s\n{self.describe()}")

    def applied(self, start: int = 0) -> list[dict]:
        with self.cond:
            return [e for e in self.events[start:] if e["event"] == "applied"]

    def send(self, command: str) -> None:
        """A stdin command of LiveClient.cs: pause, resume, blur, focus."""
        self.proc.stdin.write(command + "\n")
        self.proc.stdin.flush()

    def quit(self) -> int:
        if self.proc.poll() is None:
            try:
                self.proc.stdin.write("quit\n")
                self.proc.stdin.flush()
            except OSError:
                pass
        try:
            return self.proc.wait(15)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(5)
            pytest.fail(f"LiveClient did not quit\n{self.describe()}")

    def kill(self):
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(5)



def _serve_help() -> str:
    r = subprocess.run([sys.executable, "-m", "provider.cli", "serve", "--help"], cwd=ROOT,
                       capture_output=True, text=True, timeout=60)
    return r.stdout


