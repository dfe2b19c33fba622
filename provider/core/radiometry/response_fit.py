"""How well a response curve explains its own bracket, and a fit chosen by that (no I/O).

A curve is right where two frames of one pixel agree: for a pixel well exposed in two
frames (codes 1..254 in both) the radiance each frame gives, ``g(z)/t``, should be the
same. :func:`disagreement` measures ``|g(z_a)/t_a ÷ g(z_b)/t_b − 1|`` over every such pixel
of every pair of neighbouring exposures, per code range (each pair counts in the ranges of
both its codes): the median and the 90th percentile, in the same units for any curve, sRGB
included. That is the number :func:`fit_response` minimises:

* samples spread evenly over the scene's radiance (estimated from the bracket), taken in
  smooth parts of the view, so that the toe and the shoulder get as many as the mid-tones;
* Debevec's least squares solved here (the sample radiances eliminated: a 256×256 system),
  so thousands of samples cost milliseconds; its smoothness lambda chosen among a few by the
  disagreement on all the pixels (not the samples); OpenCV's Robertson and OpenCV's own
  Debevec solved beside it, and the curve that explains the frames best kept;
* a robust fit on *all* the pixel pairs beside it (:func:`_pairs_l1`: the sum of
  ``|ln g(z_a) − ln g(z_b) − ln(t_a/t_b)|`` minimised by reweighted least squares, the
  measure's own terms), which pairs no curve can explain (film fog: one code at twice the
  exposure) cannot pull as they pull a least-squares fit;
* codes with too little data, or explained worse than the rest (the *trusted range* is the
  rest), continued by a monotone extrapolation from the trusted edge (or from a few fixed
  codes below it) instead of whatever the solve left there;
* among all these, a curve at least as good as sRGB in every code range is preferred: a
  calibration must not explain the frames worse than the assumption it replaces; and of
  those that explain the frames within :data:`SCORE_SLACK` of the best, the smoothest
  (:func:`roughness`): a bracket of equal steps cannot see a ripple of one step's period.
"""
from __future__ import annotations

import math

import cv2
import numpy as np

#: (name, first code, last code): the code ranges the disagreement is reported in.
CODE_RANGES = (("toe", 1, 15), ("shadows", 16, 63), ("mid-tones", 64, 191),
               ("highlights", 192, 239), ("shoulder", 240, 254))
#: The smoothness weights tried (times the data weight per code, see :func:`_debevec`).
LAMBDAS = (30.0, 100.0, 300.0, 1000.0, 3000.0, 10000.0)
#: The smoothness weights of the robust fit on all pixel pairs (:func:`_pairs_l1`).
L1_LAMBDAS = (100.0, 300.0, 1000.0, 3000.0, 10000.0)
#: Curves whose score is within this fraction of the best explain the frames as well: the
#: smoothest of them is kept (:func:`roughness`). Why: a bracket of equal steps says nothing
#: of a ripple of ln g whose period is one step (every pair of frames agrees with it), and
#: the least-smoothed fits let the sensor's noise and the codes' rounding in the toe and the
#: shoulder set one; on the noisy camera that clips 2.5 EV above mid-grey (±4 EV in 2 EV
#: steps) the best-scoring curve rippled ±15 %, differently per channel (a 6,500 K room read
#: 7,136 K), 4 % better scored than a curve within 1 % of the truth. The truth itself scores
#: worse than both (its frames are noisy).
SCORE_SLACK = 0.05
#: Codes the toe is also extrapolated from, below the trusted range's own first code.
TOE_CUTS = (16, 24, 32, 48)
#: Pixel pairs a code needs (per channel) to be inside the trusted range.
TRUST_SUPPORT = 20
_MAX_PIXELS = 120_000


def _pixels(frames: list) -> np.ndarray:
    """(F, P, 3) uint8 codes of an even subset of at most ~120k pixels of every frame."""
    h, w = frames[0].shape[:2]
    step = max(1, int(math.sqrt(h * w / _MAX_PIXELS)))
    return np.stack([f[::step, ::step].reshape(-1, 3) for f in frames])


def _pairs(codes: np.ndarray, times: np.ndarray, c: int):
    """Neighbouring exposures' codes well exposed in both, as a histogram: the code pairs
    (z_a, z_b) that occur, ln t_a − ln t_b of each, and how many pixels have them."""
    order = np.argsort(times)
    za, zb, dl, n = [], [], [], []
    for i, j in zip(order[:-1], order[1:]):
        a, b = codes[i, :, c].astype(np.int64), codes[j, :, c].astype(np.int64)
        ok = (a > 0) & (a < 255) & (b > 0) & (b < 255)
        counts = np.bincount(a[ok] * 256 + b[ok], minlength=65536)
        occur = np.flatnonzero(counts)
        za.append(occur // 256)
        zb.append(occur % 256)
        n.append(counts[occur])
        dl.append(np.full(occur.size, math.log(times[i] / times[j])))
    return np.concatenate(za), np.concatenate(zb), np.concatenate(dl), np.concatenate(n)


def _quantiles(values: np.ndarray, weights: np.ndarray, qs) -> list:
    order = np.argsort(values)
    v, cw = values[order], np.cumsum(weights[order])
    return [float(v[min(np.searchsorted(cw, q * cw[-1]), v.size - 1)]) for q in qs]


def pair_histograms(codes: np.ndarray, times) -> list:
    """:func:`_pairs` of each channel, computed once for many curves."""
    return [_pairs(codes, np.asarray(times, np.float64), c) for c in range(3)]


def disagreement(table: np.ndarray, frames, times, pairs: list | None = None) -> dict:
    """Per code range: ``median`` and ``p90`` of the relative disagreement between two
    frames' radiance ``g(z)/t`` (a fraction: 0.05 = 5 %), and ``pairs`` counted. ``table``:
    (256, 3) inverse response (any scale); frames: 8-bit, with their times in seconds."""
    if pairs is None:
        codes = frames if isinstance(frames, np.ndarray) and frames.ndim == 3 \
            else _pixels(frames)
        pairs = pair_histograms(codes, times)
    logg = np.log(np.maximum(np.asarray(table, np.float64), 1e-300))
    per_range = {name: ([], []) for name, _, _ in CODE_RANGES}
    for c in range(3):
        za, zb, dl, n = pairs[c]
        d = np.expm1(np.abs(logg[za, c] - logg[zb, c] - dl))
        for name, lo, hi in CODE_RANGES:
            for z in (za, zb):
                inside = (z >= lo) & (z <= hi)
                per_range[name][0].append(d[inside])
                per_range[name][1].append(n[inside])
    out = {}
    for name, (ds, ns) in per_range.items():
        d, n = np.concatenate(ds), np.concatenate(ns)
        if n.sum():
            med, p90 = _quantiles(d, n, (0.5, 0.9))
            out[name] = {"median": med, "p90": p90, "pairs": int(n.sum())}
        else:
            out[name] = {"median": None, "p90": None, "pairs": 0}
    return out


def score(report: dict) -> float:
    """One number to compare curves: the mean over the code ranges with data of the median
    and the 90th percentile (the mid-tones weigh twice: most light is there)."""
    total, weight = 0.0, 0.0
    for name, r in report.items():
        if r["pairs"] >= 50:
            k = 2.0 if name == "mid-tones" else 1.0
            total += k * (r["median"] + r["p90"]) / 2
            weight += k
    return total / weight if weight else math.inf


def extrapolate(table: np.ndarray, lo: int, hi: int, span: int = 12,
                shape: str = "log-linear") -> np.ndarray:
    """Codes below ``lo`` and above ``hi`` continued from the trusted edge, monotone:
    ``shape`` "log-linear" (the slope of ln g over the ``span`` edge codes, never flatter
    than 0.1 % per code) or "srgb" (sRGB's shape, scaled to meet the edge). ``lo`` and
    ``hi`` are codes, or one code per channel (each channel's own toe and shoulder)."""
    out = np.array(table, np.float64)
    logg = np.log(np.maximum(out, 1e-300))
    log_srgb = np.log(np.maximum(_SRGB, 1e-7))
    los, his = np.broadcast_to(lo, 3), np.broadcast_to(hi, 3)
    for c in range(3):
        lo, hi = int(los[c]), int(his[c])
        if lo > 0:
            if shape == "srgb":
                logg[:lo, c] = logg[lo, c] + log_srgb[:lo] - log_srgb[lo]
            else:
                k = max((logg[min(lo + span, hi), c] - logg[lo, c])
                        / max(min(span, hi - lo), 1), 1e-3)
                logg[:lo, c] = logg[lo, c] - k * (lo - np.arange(0, lo))
        if hi < 255:
            if shape == "srgb":
                logg[hi + 1:, c] = logg[hi, c] + log_srgb[hi + 1:] - log_srgb[hi]
            else:
                k = max((logg[hi, c] - logg[max(hi - span, lo), c])
                        / max(min(span, hi - lo), 1), 1e-3)
                logg[hi + 1:, c] = logg[hi, c] + k * (np.arange(hi + 1, 256) - hi)
    return np.exp(logg)


def _weights() -> np.ndarray:
    z = np.arange(256, dtype=np.float64)
    w = np.minimum(z, 255 - z)          # Debevec's hat; codes 0 and 255 (clipped) weigh 0
    return w / w.max()


def _choose_samples(codes: np.ndarray, times: np.ndarray, c: int, n: int,
                    smooth: np.ndarray) -> np.ndarray:
    """Indices of ``n`` pixels spread evenly over ln radiance (estimated with sRGB), from
    the smooth ones (``smooth``: bool per pixel) where there are enough."""
    lin = _SRGB[codes[:, :, c]]                                     # (F, P)
    ok = (codes[:, :, c] > 4) & (codes[:, :, c] < 251)
    with np.errstate(divide="ignore", invalid="ignore"):
        lnE = np.where(ok, np.log(np.maximum(lin, 1e-12) / times[:, None]), 0).sum(0) / \
            ok.sum(0)
    seen = ok.sum(0) > 0
    lnE = np.where(seen, lnE, np.nan)
    # pixels never well exposed: those under the darkest frame's toe or over the shoulder
    dark = (codes[:, :, c] <= 4).all(0)
    bright = (codes[:, :, c] >= 251).all(0)
    finite = lnE[np.isfinite(lnE)]
    if finite.size == 0:
        return np.zeros(0, np.int64)
    lnE = np.where(dark, finite.min() - 1, np.where(bright, finite.max() + 1, lnE))
    bins = np.linspace(lnE.min(), lnE.max() + 1e-9, 65)
    idx = np.clip(np.digitize(lnE, bins) - 1, 0, 63)
    rng = np.random.default_rng(0)
    chosen = []
    per_bin = max(1, n // 64)
    for b in range(64):
        members = np.flatnonzero((idx == b) & smooth)
        if members.size < per_bin:
            members = np.flatnonzero(idx == b)
        if members.size:
            chosen.append(rng.choice(members, min(per_bin, members.size), replace=False))
    return np.concatenate(chosen) if chosen else np.zeros(0, np.int64)


_SRGB = np.where(np.arange(256) / 255 <= 0.04045, np.arange(256) / 255 / 12.92,
                 ((np.arange(256) / 255 + 0.055) / 1.055) ** 2.4)


def _debevec(z: np.ndarray, lnt: np.ndarray, lam: float) -> np.ndarray:
    """ln g (256,) from samples ``z`` (N, F) at ``lnt`` (F,): Debevec & Malik's weighted
    least squares with the sample radiances eliminated (Schur complement), smoothness
    ``lam`` times the mean data weight per code, g(128) = 0."""
    w = _weights()
    a = w[z] ** 2                                          # (N, F)
    s = a.sum(1)
    keep = s > 0
    z, a, s = z[keep], a[keep], s[keep]
    H = np.zeros((256, 256))
    b = np.zeros(256)
    np.add.at(H, (z.ravel(), z.ravel()), a.ravel())
    np.add.at(b, z.ravel(), (a * lnt).ravel())
    U = np.zeros((z.shape[0], 256))
    rows = np.repeat(np.arange(z.shape[0]), z.shape[1])
    np.add.at(U, (rows, z.ravel()), a.ravel())
    H -= U.T @ (U / s[:, None])
    b -= U.T @ ((a * lnt).sum(1) / s)
    D = _second_differences()
    strength = lam * a.sum() / 256
    H += strength * D.T @ (w[1:255, None] ** 2 * D)
    H[128, 128] += 1e6 * max(strength, 1.0)                # g(128) = 0 (the scale)
    return np.linalg.solve(H, b)


def _second_differences() -> np.ndarray:
    """(254, 256): row k is ln g(k) − 2 ln g(k+1) + ln g(k+2), the smoothness term's operator."""
    d = np.zeros((254, 256))
    k = np.arange(254)
    d[k, k], d[k, k + 1], d[k, k + 2] = 1.0, -2.0, 1.0
    return d


def _pairs_l1(pairs: list, lam: float, iterations: int = 30) -> np.ndarray:
    """(256, 3) inverse response minimising Σ n·|ln g(z_a) − ln g(z_b) − ln(t_a/t_b)| over
    every pixel pair of :func:`pair_histograms` (the disagreement's own terms, so its
    median rather than its mean), plus ``lam`` × the mean weight per code × the squared
    second differences of ln g; iteratively reweighted least squares from sRGB, g(128) = 1.
    Codes no pair holds follow the smoothness."""
    d = _second_differences()
    smooth = d.T @ d
    out = np.empty((256, 3))
    for c in range(3):
        za, zb, dl, n = pairs[c]
        n = n.astype(np.float64)
        x = np.log(np.maximum(_SRGB, 1e-7))
        x -= x[128]
        for _ in range(iterations):
            w = n / np.maximum(np.abs(x[za] - x[zb] - dl), 1e-3)
            cross = np.bincount(za * 256 + zb, w, 65536).reshape(256, 256)
            H = np.diag(np.bincount(za, w, 256) + np.bincount(zb, w, 256)) - cross - cross.T
            b = np.bincount(za, w * dl, 256) - np.bincount(zb, w * dl, 256)
            H += lam * w.sum() / 256 * smooth
            H[128, 128] += 1e6 * w.sum()
            x = np.linalg.solve(H, b)
        out[:, c] = np.exp(x - x[128])
    return out


def _smooth_pixels(frames, times) -> np.ndarray:
    """Per pixel of :func:`_pixels`: whether the middle exposure is locally flat there."""
    mid = frames[int(np.argsort(times)[len(times) // 2])]
    grey = cv2.cvtColor(mid, cv2.COLOR_RGB2GRAY).astype(np.float32)
    grad = cv2.absdiff(cv2.blur(grey, (5, 5)), grey)
    h, w = grey.shape
    step = max(1, int(math.sqrt(h * w / _MAX_PIXELS)))
    g = grad[::step, ::step].reshape(-1)
    return g <= np.percentile(g, 60)


def per_code(table: np.ndarray, pairs: list, per_channel: bool = False) -> np.ndarray:
    """(256,) the worst channel's median disagreement of the pixel pairs with each code
    (NaN where fewer than :data:`TRUST_SUPPORT` pairs in any channel), or with
    ``per_channel`` (256, 3) each channel's own; ``pairs``: :func:`pair_histograms`."""
    logg = np.log(np.maximum(np.asarray(table, np.float64), 1e-300))
    out = np.full((256, 3), np.nan)
    for c in range(3):
        za, zb, dl, n = pairs[c]
        d = np.expm1(np.abs(logg[za, c] - logg[zb, c] - dl))
        z = np.concatenate([za, zb])
        d, n = np.concatenate([d, d]), np.concatenate([n, n])
        order = np.lexsort((d, z))
        z, d, n = z[order], d[order], n[order]
        edges = np.searchsorted(z, np.arange(257))
        for code in range(256):
            a, b = edges[code], edges[code + 1]
            if n[a:b].sum() >= TRUST_SUPPORT:
                cw = np.cumsum(n[a:b])
                out[code, c] = d[a + np.searchsorted(cw, cw[-1] / 2)]
    return out if per_channel else out.max(axis=1)      # NaN in any channel: NaN


def trusted_codes(table: np.ndarray, pairs: list, channel: int | None = None) -> tuple[int, int]:
    """The widest run of codes around mid-grey (118) where the curve explains the frames:
    enough pixel pairs, and a median disagreement within 3× the mid-tones' (at least 10 %;
    the mid-tones of the worst channel), in every channel, or in ``channel`` (0, 1, 2)
    alone (so each channel's run holds the common one). Film's fog and a sensor's noise
    floor end it in the toe, clipping in the shoulder."""
    d = per_code(table, pairs, True)
    worst = d.max(axis=1)
    mid = np.nanmedian(worst[64:192]) if np.any(np.isfinite(worst[64:192])) else 0.1
    bound = max(3 * mid, 0.10)
    d = worst if channel is None else d[:, channel]
    ok = np.isfinite(d) & (d <= bound)
    lo = hi = 118
    while lo > 1 and ok[lo - 1]:
        lo -= 1
    while hi < 254 and ok[hi + 1]:
        hi += 1
    return lo, hi


def fit_response(frames, times, samples: int = 1000, lambdas=LAMBDAS,
                 others: dict | None = None, beside: dict | None = None,
                 pairs: list | None = None):
    """The (256, 3) inverse response that explains ``frames`` best (any scale: the
    smoothest of the curves within :data:`SCORE_SLACK` of the best score), with what
    was tried: ``(table, info)``; ``info``: ``method``, ``lambda`` (Debevec's or the robust
    fit's, or None), ``samples``, ``trusted`` (lo, hi) in every channel, ``trusted_rgb``
    ((lo, hi) of each channel), ``extrapolated``, ``candidates``
    {name: score}, ``beats_srgb`` (whether the curve is at least as good as sRGB in every
    code range with data). ``others``: more candidate tables by name (OpenCV's Debevec);
    ``beside``: tables scored and reported but never chosen (OpenCV's Robertson: on a
    simulated camera it explains the frames better than the true curve does while 5 % off
    it, so the score cannot choose it). ``pairs``: the frames' :func:`pair_histograms`,
    where the caller has them already."""
    times = np.asarray(times, np.float64)
    codes = _pixels(frames)
    lnt = np.log(times)
    smooth = _smooth_pixels(frames, times)
    if pairs is None:
        pairs = pair_histograms(codes, times)
    candidates = {}
    for lam in lambdas:
        table = np.empty((256, 3))
        for c in range(3):
            pick = _choose_samples(codes, times, c, samples, smooth)
            table[:, c] = np.exp(_debevec(codes[:, pick, c].T.astype(np.int64), lnt, lam))
        candidates[("debevec", lam)] = _monotone(table)
    for lam in L1_LAMBDAS:
        candidates[("pairs-l1", lam)] = _monotone(_pairs_l1(pairs, lam))
    for name, table in (others or {}).items():
        candidates[(name, None)] = _monotone(table)
    reports = {k: disagreement(t, codes, times, pairs) for k, t in candidates.items()}
    # the best fits, and the smoothest of those within SCORE_SLACK of the best, with their
    # untrusted codes (toe, shoulder or both) extrapolated; the toe also from a few fixed
    # codes below the trusted range (film's fog ends it gradually)
    trusted = {}
    ranked = sorted(reports, key=lambda k: score(reports[k]))
    floor = score(reports[ranked[0]]) * (1 + SCORE_SLACK)
    smoothest = min((k for k in ranked if score(reports[k]) <= floor),
                    key=lambda k: roughness(candidates[k]))
    per_channel = {}
    for base in dict.fromkeys(ranked[:3] + [smoothest]):
        lo, hi = trusted[base] = trusted_codes(candidates[base], pairs)
        own = per_channel[base] = [trusted_codes(candidates[base], pairs, c) for c in range(3)]
        cuts = [("toe", lo, 255), ("shoulder", 0, hi), ("toe and shoulder", lo, hi),
                ("each channel's toe and shoulder", [a for a, _ in own], [b for _, b in own])]
        cuts += [(f"toe from {cut}", cut, 255) for cut in TOE_CUTS if cut < lo]
        for shape in ("log-linear", "srgb"):
            for name, a, b in cuts:
                key = base + (f"{name} ({shape})",)
                candidates[key] = extrapolate(candidates[base], a, b, shape=shape)
                reports[key] = disagreement(candidates[key], codes, times, pairs)
    srgb = disagreement(_SRGB[:, None].repeat(3, 1), codes, times, pairs)
    scores = {k: score(r) for k, r in reports.items()}
    good = [k for k, r in reports.items() if _as_good(r, srgb)]
    pool = good or list(scores)
    floor = min(scores[k] for k in pool) * (1 + SCORE_SLACK)
    # the smoothest over the codes the smoothest base trusts (extrapolation changes only
    # the rest), then the best scored of its family
    span = trusted[smoothest]       # one range for all: a ripple shows anywhere in it
    best = min((k for k in pool if scores[k] <= floor),
               key=lambda k: (roughness(candidates[k], *span), scores[k]))
    reported = {}
    for (m, lam, *extra), s in scores.items():
        reported[f"{m}" + (f" lambda {lam:g}" if lam is not None else "")
                 + (f", {extra[0]} extrapolated" if extra else "")] = round(s, 5)
    for name, table in (beside or {}).items():
        reported[f"{name} (not chosen)"] = round(score(disagreement(
            _monotone(table), codes, times, pairs)), 5)
    info = {"method": best[0], "lambda": best[1], "samples": int(samples),
            "trusted": [int(v) for v in trusted.get(best[:2], next(iter(trusted.values())))],
            "trusted_rgb": [[int(a), int(b)] for a, b in per_channel.get(
                best[:2], next(iter(per_channel.values())))],
            "extrapolated": best[2] if len(best) > 2 else None, "candidates": reported,
            "beats_srgb": best in good}
    return candidates[best], info


def roughness(table: np.ndarray, lo: int = 16, hi: int = 250) -> float:
    """Mean square second difference of ln g over codes lo..hi, all channels: a ripple
    the frames cannot see (:data:`SCORE_SLACK`) raises it; a camera's tone curve is smooth."""
    logg = np.log(np.maximum(np.asarray(table, np.float64)[lo:hi + 1], 1e-300))
    return float(np.mean(np.diff(logg, 2, axis=0) ** 2))


def _as_good(report: dict, srgb: dict) -> bool:
    """Whether a curve's disagreement is at most sRGB's, median and 90th percentile, in every
    code range with data."""
    return all(r["pairs"] < 50 or (r["median"] <= srgb[n]["median"] + 1e-9
                                   and r["p90"] <= srgb[n]["p90"] + 1e-9)
               for n, r in report.items())


def _monotone(table: np.ndarray) -> np.ndarray:
    t = np.array(table, np.float64)
    t[~np.isfinite(t) | (t <= 0)] = np.nan
    for c in range(3):
        col = t[:, c]
        ok = np.isfinite(col)
        if ok.sum() >= 2 and not ok.all():
            z = np.arange(256)
            col[~ok] = np.exp(np.interp(z[~ok], z[ok], np.log(col[ok])))
        col[~np.isfinite(col)] = 1e-6
        for z in range(129, 256):
            col[z] = max(col[z], col[z - 1] * 1.0001)
        for z in range(127, -1, -1):
            col[z] = min(col[z], col[z + 1] / 1.0001)
    return t


#: A frame whose light differs from its bracket's by more than this (stops) is said
#: (``shlight calibrate-response`` warns): 0.1 stop is 7 %, beyond a rounded marked shutter
#: speed (1/60 s for 1/64 s is 0.09 stop), and it moves the absolute scale.
FRAME_DISAGREEMENT_WARN_STOPS = 0.1


def frame_disagreement(frames, times, response) -> list:
    """Per frame, in stops: how far its light, ``g(z)/t``, lies from what the *other*
    frames merge to (:func:`~.bracket.merge`), the median over the samples it has on the
    curve's trusted codes and the others measured (None for a frame with fewer than 100).
    A frame whose exposure time, f-number or ISO is not what the camera did (a rounded or
    wrong EXIF, a frame of another bracket) stands out; the absolute scale carries it."""
    from .bracket import merge, trusted_ranges
    times = np.asarray(times, np.float64)
    h, w = frames[0].shape[:2]
    step = max(1, int(math.sqrt(h * w / _MAX_PIXELS)))
    small = [np.ascontiguousarray(f[::step, ::step]) for f in frames]
    ranges = trusted_ranges(response) or (16, 250)
    ranges = [ranges] * 3 if np.ndim(ranges) == 1 else ranges
    lo = np.array([r[0] for r in ranges])
    hi = np.array([r[1] for r in ranges])
    out = []
    for i, frame in enumerate(small):
        others = [f for j, f in enumerate(small) if j != i]
        if not others:
            out.append(None)
            continue
        merged = merge(others, np.delete(times, i), response).radiance
        own = response.linearise(frame, float(times[i]))
        ok = ((frame >= lo) & (frame <= hi) & (merged > 0) & (own > 0)
              & (np.minimum.reduce(others) < 255) & (np.maximum.reduce(others) > 0))
        if np.count_nonzero(ok) < 100:
            out.append(None)
            continue
        out.append(float(np.median(np.log2(own[ok] / merged[ok]))))
    return out


def calibrate_best(frames, times, *, samples: int = 1000, lambdas=LAMBDAS):
    """A :class:`~provider.core.radiometry.response.CameraResponse` from the curve
    :func:`fit_response` keeps (the smoothest of those that explain the bracket within
    :data:`SCORE_SLACK` of the best; OpenCV's Debevec and Robertson beside them), with
    ``params["quality"]``: the disagreement of this curve and of sRGB per code range, and
    ``params["trusted_codes"]`` (the codes every channel explains) and
    ``params["trusted_codes_rgb"]`` (each channel's own). Bad input raises
    :class:`.response.ResponseError`."""
    from .response import ANCHOR_VALUE, ANCHOR_WINDOW_8, CameraResponse, ResponseError, calibrate
    opencv = {}
    for method in ("debevec", "robertson"):
        try:
            opencv[method] = calibrate(frames, times, method).table
        except ResponseError as exc:
            if "failed" not in str(exc):
                raise                      # bad input: the same words as calibrate's
    frames = [np.ascontiguousarray(f) for f in frames]
    pairs = pair_histograms(_pixels(frames), times)     # once: the fit scores with them too
    table, info = fit_response(
        frames, times, samples=samples, lambdas=lambdas,
        others={"opencv-debevec": opencv["debevec"]} if "debevec" in opencv else {},
        beside={"opencv-robertson": opencv["robertson"]} if "robertson" in opencv else {},
        pairs=pairs)
    lo, hi = ANCHOR_WINDOW_8
    table = table * (ANCHOR_VALUE / np.exp(np.log(table[lo:hi + 1]).mean(axis=0)))
    mine = disagreement(table, None, times, pairs)
    srgb = disagreement(CameraResponse.srgb().table, None, times, pairs)
    if not any(r["pairs"] for r in mine.values()):
        raise ResponseError("no pixel is well exposed (codes 1-254) in two frames: are the "
                            "frames all black, all white, or not one view?")
    method = "debevec"
    params = {"fit": info, "trusted_codes": info["trusted"],
              "trusted_codes_rgb": info["trusted_rgb"],
              "quality": {"curve": mine, "srgb": srgb}, "samples": info["samples"],
              "lambda": info["lambda"]}
    return CameraResponse(table, method=method, exposure_times=list(map(float, times)),
                          params=params)
