"""Car-following look-ups: where the trams' bodies lie on each other's tracks.

Leaders are other trams whose front or rear lies on a tram's extended track ahead of it,
whatever their own route (an oncoming tram on single track counts too; a tram that joined
the route at a merge occupies it only from the merge on). :class:`BodyLocator` finds all
such matches for all trams at once with one vectorised look-up; the driver model in
:mod:`antikol.sim.dynamics` picks the leaders from them.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from antikol.sim.track import Track

__all__ = ["BodyLocator"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]


class BodyLocator:
    """The extended tracks of all trams, indexed by edge, for locating body points.

    Parameters
    ----------
    tracks : sequence of Track
        Each tram's extended track, in tram order.
    length_m : ndarray
        Each tram's length, metres.
    """

    def __init__(self, tracks: Sequence[Track], length_m: FloatArray) -> None:
        f = np.array
        self.length = length_m
        keys, g_edge, g_dir, g_b0, g_len, g_tram, first, last = [], [], [], [], [], [], [], []
        shift = []
        pos = 0
        acc = 0.0
        for index, tr in enumerate(tracks):
            off = acc - tr.b0[0]
            shift.append(off)
            keys.append(tr.b0 + off)
            g_edge.append(tr.edge)
            g_dir.append(tr.dir)
            g_b0.append(tr.b0)
            g_len.append(tr.len)
            g_tram.append(np.full(len(tr.edge), index, dtype=np.int64))
            first.append(pos)
            pos += len(tr.edge)
            last.append(pos - 1)
            acc = float(tr.b1[-1] + off) + 1e4
        cat = np.concatenate
        self.g_key = cat(keys) if keys else np.zeros(0)
        self.g_edge = cat(g_edge) if keys else np.zeros(0, dtype=np.int64)
        self.g_dir = cat(g_dir) if keys else np.zeros(0, dtype=np.int64)
        self.g_b0 = cat(g_b0) if keys else np.zeros(0)
        self.g_len = cat(g_len) if keys else np.zeros(0)
        self.g_tram = cat(g_tram) if keys else np.zeros(0, dtype=np.int64)
        self.g_shift = f(shift, dtype=float)
        self.g_first = f(first, dtype=np.int64)
        self.g_last = f(last, dtype=np.int64)
        order = np.argsort(self.g_edge, kind="stable")
        self.e_g = order
        self.e_sorted = self.g_edge[order]
        self.e_tram = self.g_tram[order]
        self.e_dir = self.g_dir[order]
        self.e_b0 = self.g_b0[order]
        self.e_len = self.g_len[order]

    def matches(
        self, s: FloatArray, present: BoolArray
    ) -> tuple[IntArray, FloatArray, FloatArray, FloatArray, FloatArray, IntArray]:
        """Body points of present trams found on every tram's extended track.

        Returns, per match: the tram whose track it is, the point's route distance on it,
        the near end of the body as if the body lay on that track (it moves with the
        owner), the point where the owner's track joined it (the near end cannot be
        before it; -inf when not known), +1/-1 for same/opposite running, and the owner.
        """
        owners = np.flatnonzero(present)
        n_o = len(owners)
        qs = np.concatenate((s[owners], s[owners] - self.length[owners]))
        qo = np.concatenate((owners, owners))
        is_front = np.concatenate((np.ones(n_o, dtype=bool), np.zeros(n_o, dtype=bool)))
        gk = np.searchsorted(self.g_key, qs + self.g_shift[qo], side="right") - 1
        gk = np.clip(gk, self.g_first[qo], self.g_last[qo])
        rel = qs - self.g_b0[gk]
        pe = self.g_edge[gk]
        pdir = self.g_dir[gk]
        plen = self.g_len[gk]
        po = np.clip(np.where(pdir > 0, rel, plen - rel), 0.0, plen)
        lo = np.searchsorted(self.e_sorted, pe, side="left")
        hi = np.searchsorted(self.e_sorted, pe, side="right")
        cnt = hi - lo
        total = int(cnt.sum())
        empty_i = np.zeros(0, dtype=np.int64)
        empty_f = np.zeros(0)
        if total == 0:
            return empty_i, empty_f, empty_f, empty_f, empty_f, empty_i
        rep = np.repeat(np.arange(len(qs)), cnt)
        within = np.arange(total) - np.repeat(np.cumsum(cnt) - cnt, cnt)
        iv = np.repeat(lo, cnt) + within
        mt = self.e_tram[iv]
        owner = qo[rep]
        keep = mt != owner
        iv, rep, mt, owner = iv[keep], rep[keep], mt[keep], owner[keep]
        d_iv = self.e_dir[iv]
        md = self.e_b0[iv] + np.where(d_iv > 0, po[rep], self.e_len[iv] - po[rep])
        sign = np.where(d_iv == pdir[rep], 1.0, -1.0)
        front = is_front[rep]
        # the body extends behind the front (same running: towards us)
        toward = front == (sign > 0)
        mtail = np.where(toward, md - self.length[owner], md)
        mjoin = np.full(len(md), -np.inf)
        # A front that joined our track at a merge: the body is on our track only from
        # where both tracks have run the same steps (walk back while they agree).
        walk = np.flatnonzero(front & (sign > 0))
        if len(walk):
            cur_m = self.e_g[iv[walk]]
            cur_o = gk[rep[walk]]
            tw = mt[walk]
            ow = owner[walk]
            tail = mtail[walk]
            join = self.g_b0[cur_m]
            for _ in range(64):
                can = (tail < join) & (cur_m > self.g_first[tw]) & (cur_o > self.g_first[ow])
                can[can] &= (self.g_edge[cur_m[can] - 1] == self.g_edge[cur_o[can] - 1]) & (
                    self.g_dir[cur_m[can] - 1] == self.g_dir[cur_o[can] - 1]
                )
                if not np.count_nonzero(can):
                    break
                cur_m[can] -= 1
                cur_o[can] -= 1
                join[can] = self.g_b0[cur_m[can]]
            mjoin[walk] = join
        return mt, md, mtail, mjoin, sign, owner
