"""Pair choice (``fotogeo.stereo.pairs.choose_pairs``): the per-image cap on partners must not leave ground that two
images see without a pair — a block with long forward and short side overlap (issue 30's held-out sweep: a rendered
3 x 3 block at 80 % / 30 % lost 16 % of its two-view ground, the consecutive frames' pairs capped out by the wide
cross-strip ones)."""
import numpy as np

from fotogeo.stereo.pairs import READMIT_ACROSS, _inside, base_across, choose_pairs, overlap_polygon


def _block(strips=3, per_strip=3, along=540.0, across=720.0, forward=0.8, side=0.3, height=900.0):
    centres, footprints = [], []
    for s in range(strips):
        for k in range(per_strip):
            x, y = k * (1 - forward) * along, s * (1 - side) * across
            centres.append((x, y, height))
            footprints.append(np.array([[x - along / 2, y - across / 2, 0.0], [x + along / 2, y - across / 2, 0.0],
                                        [x + along / 2, y + across / 2, 0.0], [x - along / 2, y + across / 2, 0.0]]))
    return centres, [(0.0, 0.0, -1.0)] * len(centres), footprints


def _uncovered(footprints, pairs) -> tuple:
    xy = np.vstack(footprints)[:, :2]
    u, v = (np.linspace(a, b, 200) for a, b in zip(xy.min(axis=0), xy.max(axis=0)))
    g = np.stack(np.meshgrid(u, v), -1).reshape(-1, 2)
    seen = sum(_inside(g, f[:, :2]).astype(int) for f in footprints) >= 2
    covered = np.zeros(len(g), bool)
    for p in pairs:
        covered |= _inside(g, overlap_polygon(footprints[p.i], footprints[p.j]))
    return int(seen.sum()), int((seen & ~covered).sum())


def test_every_two_view_ground_has_a_pair_in_a_block_of_long_forward_overlap():
    c, a, f = _block()
    out = choose_pairs(c, a, f)
    kept = [p for p in out if p.kept]
    seen, uncovered = _uncovered(f, kept)
    assert seen > 1000 and uncovered == 0  # 27 % of it uncovered before
    readmitted = [p for p in kept if p.reason.startswith("kept over the")]
    assert readmitted and all("covered by no other kept pair" in p.reason for p in readmitted)


def test_a_capped_pair_whose_ground_others_cover_stays_out():
    # one strip of 6 frames at 80 %: every frame's ground is seen by 3+ others, the cap still thins the pairs
    c, a, f = _block(strips=1, per_strip=6)
    out = choose_pairs(c, a, f)
    kept = [p for p in out if p.kept]
    assert _uncovered(f, kept)[1] == 0
    assert any(p.reason.startswith("both images already have") for p in out)


def test_inside_convex_polygon_either_orientation():
    sq = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    pts = np.array([[0.5, 0.5], [1.5, 0.5], [1.0, 0.5], [-0.1, 0.2]])
    assert _inside(pts, sq).tolist() == [True, False, True, False]
    assert _inside(pts, sq[::-1]).tolist() == [True, False, True, False]


def test_capped_pairs_flown_the_way_they_look_are_not_kept_for_ground():
    # the same block looking 60 degrees below the horizon along its strips: the consecutive frames' base lies along
    # the lines of sight (b⊥/H about 0.8 of B/H); kept for ground they gave 2 GSD on it (docs/benchmarks/dsm.md)
    c, _, f = _block()
    pitch = np.radians(60.0)
    c = [(x - z / np.tan(pitch), y, z) for x, y, z in c]
    axes = [(np.cos(pitch), 0.0, -np.sin(pitch))] * len(c)
    out = choose_pairs(c, axes, f)
    capped = [p for p in out if p.reason.startswith("both images already have")]
    assert capped and not any(p.reason.startswith("kept over the") for p in out)
    assert all(base_across(p) < READMIT_ACROSS * p.base_height for p in capped)
