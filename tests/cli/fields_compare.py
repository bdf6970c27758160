"""Shared by the ctest scripts here: compare the field snapshots of two runs' fields.h5 (full
double precision; profiles.csv holds 10 significant digits and would not show a difference in
the last bits)."""
import h5py
import numpy as np


def snapshots(path):
    """{time (rounded to 1e-9 s): group name} of a fields.h5."""
    out = {}
    with h5py.File(path, "r") as f:
        for g in f:
            t = f[g].attrs.get("time")
            if t is None:
                continue
            out[round(float(np.asarray(t).ravel()[0]), 9)] = g
    return out


def max_difference(path_a, path_b, times):
    """The largest |a - b| over every dataset of the snapshots at `times` in both files, with
    the dataset's name; (None, message) when a snapshot or dataset is missing on either side or a
    snapshot holds no dataset. NaN in both files at the same place counts as equal; NaN on one
    side only is an infinite difference (np.nanmax skipped it, so a restart that lost a field to
    NaN compared as identical: an audit of the suite, session 44)."""
    sa, sb = snapshots(path_a), snapshots(path_b)
    worst, where = 0.0, ""
    with h5py.File(path_a, "r") as fa, h5py.File(path_b, "r") as fb:
        for t in times:
            t = round(t, 9)
            if t not in sa or t not in sb:
                return None, f"no snapshot at t = {t} s in both files"
            ga, gb = fa[sa[t]], fb[sb[t]]
            names, names_b = [], []
            ga.visititems(lambda n, o: names.append(n) if isinstance(o, h5py.Dataset) else None)
            gb.visititems(lambda n, o: names_b.append(n) if isinstance(o, h5py.Dataset) else None)
            if not names:
                return None, f"no dataset in the snapshot at t = {t} s"
            for n in names_b:
                if n not in names:
                    return None, f"{n} only in the second file at t = {t} s"
            for n in names:
                if n not in gb:
                    return None, f"{n} missing at t = {t} s"
                a, b = np.asarray(ga[n][()], dtype=float), np.asarray(gb[n][()], dtype=float)
                if a.shape != b.shape:
                    return None, f"{n} has shapes {a.shape} and {b.shape} at t = {t} s"
                na, nb = np.isnan(a), np.isnan(b)
                # equal values (also infinities of one sign) differ by 0, not by inf - inf
                d = np.where(na & nb, 0.0, np.where(na | nb, np.inf,
                                                    np.where(a == b, 0.0, np.abs(a - b))))
                if d.size and float(d.max()) > worst:
                    worst, where = float(d.max()), f"{n} at t = {t} s"
    return worst, where
