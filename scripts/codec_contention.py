"""Issue 41, item 1: a 30 fps MJPEG-like camera (1920x960 JPEG frames, decoded as the
probe decodes them) beside a source reading 7680x3840 PNGs back to back: the camera's frames a
second. Usage, from a checkout: PYTHONPATH=$PWD .venv/bin/python scripts/codec_contention.py 15
(the provider measured is the one imported)."""
import os
import shutil
import sys
import tempfile
import threading
import time

import cv2
import numpy as np

import provider
from provider.live.sources.base import Frame, Pacer, Source
from provider.live.sources.files import SequenceSource

secs = float(sys.argv[1])
folder = tempfile.mkdtemp()
img = np.random.default_rng(0).integers(0, 256, (3840, 7680, 3), np.uint8)
img[:, :, 1] //= 4
cv2.imwrite(os.path.join(folder, "room.png"), img, [cv2.IMWRITE_PNG_COMPRESSION, 1])
h, w = 960, 1920
ramp = np.linspace(0.2, 1, h)[:, None, None] * np.linspace(0, 1, w)[None, :, None]
cam = (ramp * np.array([255, 200, 150]) + np.random.default_rng(1).random((h, w, 3)) * 30)
jpeg = cv2.imencode(".jpg", cam.clip(0, 255).astype(np.uint8), [cv2.IMWRITE_JPEG_QUALITY, 90])[1].tobytes()
stop = threading.Event()
counts = {"camera": 0, "png": 0}
lat = []
def camera():
    src = Source(); pacer = Pacer(30)
    while not stop.is_set():
        pacer.wait(src); t = time.monotonic()
        Frame(None, time.time(), jpeg=jpeg).decoded(); counts["camera"] += 1
        lat.append(time.monotonic() - t)
def pngs():
    seq = SequenceSource(folder, fps=1e6); seq.open()
    while not stop.is_set():
        seq.read(); counts["png"] += 1
threads = [threading.Thread(target=camera), threading.Thread(target=pngs)]
for t in threads: t.start()
time.sleep(secs); stop.set()
for t in threads: t.join()
shutil.rmtree(folder)
lat.sort()
print(f"{provider.__file__}: camera {counts['camera'] / secs:.1f} frames/s (decode p50 "
      f"{lat[len(lat)//2]*1e3:.1f} ms, p99 {lat[int(len(lat)*0.99)]*1e3:.0f} ms), PNG reads "
      f"{counts['png'] / secs:.2f}/s")
