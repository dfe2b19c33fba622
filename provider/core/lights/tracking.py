"""Lights that are stable in time: hysteresis across frames (docs/contract.md §10).

A pure state machine (no threads, no I/O, no clock): the live layer keeps one
:class:`LightTracker` per probe and feeds it each frame's
:class:`~provider.core.lights.analysis.Analysis` (the engine does this when
``SH9Projector.project(frame, tracker=...)`` is given one). A single image
(``compute_sh9``, ``shlight compute``) has no history and uses the per-frame greedy choice.

Measured on the demo scene (a moving sun, a lamp switching every 3 s) and a stress version
where the lamp's gain crosses the sun's: the per-frame greedy choice flips sun→lamp→sun 13
times in 10 s, the tracker never (tests/core/lights/test_lights.py holds both).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .analysis import Analysis, LightsResult


@dataclass
class _Track:
    key: int
    direction: np.ndarray
    level: int
    active: bool = False
    hits: int = 0              # consecutive frames a pending track qualified to be added
    weak: int = 0              # consecutive frames an active light did not earn its keep
    swap_hits: int = 0         # consecutive frames it beat the weakest active light
    alt_level: int | None = None
    alt_hits: int = 0          # consecutive frames another level of it was clearly better


class LightTracker:
    """Hysteresis across frames, so that lights neither flicker nor swap between two lamps.

    The live layer owns one tracker per probe and feeds it each frame's :class:`Analysis`
    (``tracker.update(extractor.analyse(frame, coefficients))``). All decisions use the
    analysis' own measured errors:

    * identity: a track follows the candidate nearest its last direction (within
      ``match_deg``, the same level preferred), so a moving sun keeps its key; candidates
      nested in a tracked one (the same source at another level) are its alternatives.
    * keep: an active light stays while removing it would raise the error by at least
      ``keep_gain`` (a far lower bar than adding); it goes after ``drop_frames`` frames
      below that, at once when it makes the error worse by more than ``keep_gain``, and at
      once when its source vanishes (a lamp switched off: the flux left the frame, so
      ambient = full − light would be wrong).
    * start: the first frame after construction or :meth:`reset` has no history to be
      stable against, so its lights are chosen at once (a client that connects to a new
      stream, or a still image served live, gets its lights in the first message).
    * add: a pending track must pass the extractor's acceptance test on top of the kept
      lights for ``add_frames`` consecutive frames (capacity aside); then it takes a free
      slot at once (a lamp going off hands its slot to the sun in the same frame). Adding
      late is harmless: until then the source is in the ambient SH9, as for clients
      without lights.
    * swap: with K lights active a challenger replaces the weakest only if the swapped set's
      error is lower by ``swap_margin`` (relative), for ``add_frames`` frames in a row. The
      same rule moves an active light to another level of its own source (key unchanged).
    * order: lights are reported in key order, so wire slots do not swap either.
    """

    def __init__(self, *, max_lights: int | None = None, match_deg: float = 10.0,
                 level_penalty_deg: float = 3.0, keep_gain: float = 0.0005,
                 add_frames: int = 3, drop_frames: int = 5, swap_margin: float = 0.25):
        self.max_lights = max_lights
        self.match_deg, self.level_penalty_deg = match_deg, level_penalty_deg
        self.keep_gain, self.add_frames, self.drop_frames = keep_gain, add_frames, drop_frames
        self.swap_margin = swap_margin
        self.tracks: list[_Track] = []
        self._next = 0
        self.frames = 0                 # frames seen since construction or reset()

    def reset(self) -> None:
        """Forget every track (a new source, a reconnect, another frame size)."""
        self.tracks, self._next, self.frames = [], 0, 0

    # -- matching ---------------------------------------------------------------------------
    def _match(self, a: Analysis) -> dict:
        """track key -> candidate index, and new tracks for unmatched sources."""
        cands = a.candidates
        pairs = []
        for t in self.tracks:
            for i, c in enumerate(cands):
                ang = math.degrees(math.acos(max(-1.0, min(1.0, float(t.direction @ c.direction)))))
                if ang <= self.match_deg:
                    cost = ang + (0.0 if c.level == t.level else self.level_penalty_deg)
                    pairs.append((not t.active, cost, t.key, i))
        pairs.sort()
        match, used = {}, []
        for _, _, key, i in pairs:
            if key in match or i in used or any(a.conflict[i, j] for j in used):
                continue
            match[key] = i
            used.append(i)
        # Unmatched candidates that are no other level of a matched source start tracks,
        # one per source (its best candidate).
        free = [i for i in range(len(cands))
                if i not in used and not any(a.conflict[i, j] for j in used)]
        free.sort(key=lambda i: -cands[i].gain)
        for i in free:
            if any(a.conflict[i, j] for j in used):
                continue
            t = _Track(self._next, cands[i].direction.copy(), cands[i].level)
            self._next += 1
            self.tracks.append(t)
            match[t.key] = i
            used.append(i)
        return match

    def _alternatives(self, a: Analysis, i: int) -> list:
        return [j for j in range(len(a.candidates)) if a.conflict[i, j]]

    # -- the update ---------------------------------------------------------------------------
    def update(self, analysis: Analysis) -> LightsResult:
        """Choose this frame's lights with hysteresis; returns the :class:`LightsResult`."""
        a = analysis
        K = a.x.max_lights if self.max_lights is None else self.max_lights
        a.rank()
        cands = a.candidates
        match = self._match(a)
        self.tracks = [t for t in self.tracks if t.key in match]   # vanished sources go
        for t in self.tracks:
            if not t.active:   # a pending track shows its source's best level
                alts = [match[t.key]] + self._alternatives(a, match[t.key])
                match[t.key] = max(alts, key=lambda i: cands[i].gain)
            c = cands[match[t.key]]
            t.direction, t.level = c.direction.copy(), c.level

        def err_of(tracks, replace=None):
            idx = [match[s.key] for s in tracks]
            if replace:
                idx = [replace.get(s.key, i) for s, i in zip(tracks, idx)]
            return a.evaluate(idx)

        # 1. Keep the active lights that still earn their keep.
        chosen = [t for t in self.tracks if t.active]
        for t in sorted(chosen, key=lambda t: cands[match[t.key]].gain):
            loss = err_of([s for s in chosen if s is not t]) - err_of(chosen)
            if loss >= self.keep_gain:
                t.weak = 0
                continue
            t.weak += 1
            if t.weak >= self.drop_frames or loss < -self.keep_gain:  # useless, or harmful
                t.active, t.weak = False, 0
                chosen.remove(t)
        # 2. Another level of an active light's source, if clearly better.
        e0 = err_of(chosen)
        for t in chosen:
            best, best_e = None, e0 * (1 - self.swap_margin)
            for j in self._alternatives(a, match[t.key]):
                e = err_of(chosen, {t.key: j})
                if e < best_e and a.accepts(e0, e):
                    best, best_e = j, e
            if best is not None and cands[best].level == t.alt_level:
                t.alt_hits += 1
            else:
                t.alt_level, t.alt_hits = (None if best is None else cands[best].level), int(
                    best is not None)
            if t.alt_hits >= self.add_frames:
                match[t.key] = best
                t.level, t.direction = cands[best].level, cands[best].direction.copy()
                t.alt_level, t.alt_hits = None, 0
                e0 = err_of(chosen)
        # 3. Pending tracks: how long has each passed the acceptance test on top of the kept
        #    lights (capacity aside)? Eligible long enough = may take a free slot at once, so
        #    a light whose lamp went off is replaced in the same frame, not after a gap.
        others = [t for t in self.tracks if not t.active]

        def best_level(t, base):
            """(error, candidate) of the best level of a pending track's source on top of
            ``base`` (the level that complements the other lights, not the best alone)."""
            idx = [match[s.key] for s in base]
            opts = [match[t.key]] + self._alternatives(a, match[t.key])
            return min((a.evaluate(idx + [j]), j) for j in opts)

        for t in others:
            if a.accepts(e0, best_level(t, chosen)[0]):
                t.hits += 1
            else:
                t.hits = 0
        while len(chosen) < K:
            e_now = err_of(chosen)
            need = 1 if self.frames == 0 else self.add_frames
            ready = [t for t in others if not t.active and t.hits >= need]
            scored = [best_level(t, chosen) + (t.key, t) for t in ready]
            scored = [x for x in scored if a.accepts(e_now, x[0])]
            if not scored:
                break
            _, j, _, t = min(scored, key=lambda x: x[:3])
            match[t.key] = j
            t.level, t.direction = cands[j].level, cands[j].direction.copy()
            t.active, t.weak, t.swap_hits = True, 0, 0
            chosen.append(t)
        # 4. Swaps, only with the set full: the challenger must beat the weakest light by
        #    swap_margin (relative error) for add_frames frames in a row.
        if len(chosen) >= K and chosen:
            e_full = err_of(chosen)
            weakest = min(chosen, key=lambda t: (err_of([s for s in chosen if s is not t]), t.key))
            rest = [s for s in chosen if s is not weakest]
            best, best_e = None, e_full * (1 - self.swap_margin)
            for t in others:
                if t.active:
                    continue
                e = err_of(rest + [t])
                if e < best_e and a.accepts(e_full, e):
                    best, best_e = t, e
            for t in others:
                t.swap_hits = t.swap_hits + 1 if t is best else 0
            if best is not None and best.swap_hits >= self.add_frames:
                weakest.active = False
                best.active, best.weak, best.swap_hits = True, 0, 0
        final = sorted((t for t in self.tracks if t.active), key=lambda t: t.key)
        self.frames += 1
        return a.result([match[t.key] for t in final], keys=[t.key for t in final],
                        max_lights=K)
