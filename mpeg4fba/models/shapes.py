"""Visemes and expressions of the reference head as combinations of low-level FAPs.

Each viseme (FAP 1, 1-14) and expression (FAP 2, 1-6) is written down here as FAP
values (in FAP units, so MNS for the lips and jaw, MW for the mouth corners' stretch,
ENS for brows and cheeks, IRISD for the lids).  :func:`high_level_tables` plays each
combination on a face with its own low-level FAT and stores the result as a
FaceDefTable with interval borders [0, 63]: the displacement of every vertex that
moves, divided by 63, and the turn of every Transform that turns (the jaw), so that
``viseme_blend`` / ``expression_intensity`` 63 gives exactly the combination.

Conventions the numbers follow (see ``spec/fapu.md`` section 3): lower_t_midlip > 0
moves the upper lip *down*, raise_b_midlip > 0 the lower lip *up*, so the inner lips
part when their sum is negative; open_jaw moves the chin and the lower teeth but not
the lips ("does not affect mouth opening"), so a viseme that opens the jaw lowers
the lower lip with it by about the same value.

>>> sorted(VISEME_FAPS) == list(range(1, 15)), sorted(EXPRESSION_FAPS) == list(range(1, 7))
(True, True)
>>> VISEME_FAPS[10]["open_jaw"] > 0 and VISEME_FAPS[10]["raise_b_midlip"] < 0    # "aa"
True
"""
from __future__ import annotations

import numpy as np

from ..fba.fat import FaceDefMesh, FaceDefTable, FaceDefTransform
from ..fba.stream import FapStream
from ..fba.tables import FAP, N_FAPS

__all__ = ["VISEME_FAPS", "EXPRESSION_FAPS", "high_level_tables", "shape_values"]


def _lower_lip(v: float, spread: float = 0.85) -> dict:
    """The whole lower lip up by ``v`` MNS units (negative: down), its middle most."""
    return {"raise_b_midlip": v, "raise_b_lip_lm": v * spread, "raise_b_lip_rm": v * spread,
            "raise_b_midlip_o": v, "raise_b_lip_lm_o": v * spread, "raise_b_lip_rm_o": v * spread}


def _upper_lip(v: float, spread: float = 0.85) -> dict:
    """The whole upper lip down by ``v`` MNS units (negative: up)."""
    return {"lower_t_midlip": v, "lower_t_lip_lm": v * spread, "lower_t_lip_rm": v * spread,
            "lower_t_midlip_o": v, "lower_t_lip_lm_o": v * spread, "lower_t_lip_rm_o": v * spread}


def _corners(stretch: float = 0.0, lift: float = 0.0) -> dict:
    """Both lip corners out (MW units; negative: in) and up (MNS units)."""
    return {"stretch_l_cornerlip": stretch, "stretch_r_cornerlip": stretch,
            "stretch_l_cornerlip_o": stretch, "stretch_r_cornerlip_o": stretch,
            "raise_l_cornerlip": lift, "raise_r_cornerlip": lift,
            "raise_l_cornerlip_o": lift, "raise_r_cornerlip_o": lift}


def _pair(left: str, value: float) -> dict:
    """A left/right pair of FAPs (name with ``_l_``) at one value."""
    return {left: value, left.replace("_l_", "_r_"): value}


def _both(*parts: dict) -> dict:
    out: dict = {}
    for p in parts:
        for k, v in p.items():
            out[k] = out.get(k, 0.0) + v
    return out


def _jaw(open_: float, lip_follow: float = 0.95) -> dict:
    """Open the jaw and take the lower lip down with it."""
    return _both({"open_jaw": open_}, _lower_lip(-open_ * lip_follow))


#: viseme number -> {FAP name: value}: what the mouth does for each viseme.
VISEME_FAPS = {
    # 1 PP (p, b, m): lips closed and pressed: the outer contours close in (thinner lips)
    1: _both({"lower_t_midlip_o": 110, "lower_t_lip_lm_o": 95, "lower_t_lip_rm_o": 95,
              "raise_b_midlip_o": 170, "raise_b_lip_lm_o": 145, "raise_b_lip_rm_o": 145,
              "push_b_lip": -60, "push_t_lip": -40}, _corners(-15, 0)),
    # 2 FF (f, v): lower lip tucked up and back under the upper teeth, upper lip raised
    2: _both(_jaw(110, 0.0), _upper_lip(-160), {"raise_b_midlip": 30, "raise_b_lip_lm": 20,
             "raise_b_lip_rm": 20, "raise_b_midlip_o": 150, "raise_b_lip_lm_o": 110,
             "raise_b_lip_rm_o": 110, "push_b_lip": -280}, _corners(20, 0)),
    # 3 TH: tongue tip out between the teeth, lips apart
    3: _both(_jaw(300), _upper_lip(-110), {"thrust_tongue_tip": 280, "raise_tongue_tip": 190},
             _corners(10, 0)),
    # 4 DD (t, d): jaw a little open, tongue tip up behind the upper teeth
    4: _both(_jaw(250), _upper_lip(-90), {"raise_tongue_tip": 380, "thrust_tongue_tip": 20},
             _corners(25, 0)),
    # 5 kk (k, g): jaw open, back of the tongue raised
    5: _both(_jaw(360), _upper_lip(-90), {"raise_tongue": 320}, _corners(20, 0)),
    # 6 CH (tS, dZ, S): lips pushed out and rounded, teeth close together and showing
    6: _both(_jaw(130), _upper_lip(-190), _lower_lip(-110), {"push_t_lip": 330,
             "push_b_lip": 300}, _corners(-80, 0)),
    # 7 SS (s, z): teeth together, lips apart and spread
    7: _both(_jaw(50), _upper_lip(-150), _lower_lip(-150), _corners(90, 30)),
    # 8 nn (n, l): like DD, the tongue tip up
    8: _both(_jaw(220), _upper_lip(-70), {"raise_tongue_tip": 320}, _corners(15, 0)),
    # 9 RR (r): lips a little rounded and pushed out, the tongue bunched up
    9: _both(_jaw(170), _upper_lip(-100), {"push_t_lip": 200, "push_b_lip": 220,
             "raise_tongue": 150}, _corners(-60, 0)),
    # 10 aa: jaw wide open, lips apart
    10: _both(_jaw(900), _upper_lip(-170), _corners(20, -30)),
    # 11 E: jaw half open, lips spread
    11: _both(_jaw(480), _upper_lip(-160), _corners(80, 30)),
    # 12 ih (I): lips spread, a small opening
    12: _both(_jaw(270), _upper_lip(-140), _corners(110, 60)),
    # 13 oh (O): jaw open, lips rounded
    13: _both(_jaw(620), _upper_lip(-150), _corners(-130, 0), {"push_t_lip": 220,
              "push_b_lip": 220}),
    # 14 ou (U): small round opening, lips pushed far out
    14: _both(_jaw(260), _upper_lip(-80), _corners(-200, 0), {"push_t_lip": 420,
              "push_b_lip": 420}),
}

#: expression number -> {FAP name: value}.
EXPRESSION_FAPS = {
    # 1 joy: corners up and back, cheeks lifted, lower lids pushed up, teeth showing
    1: _both(_corners(150, 360), _jaw(190), _upper_lip(-170), _pair("lift_l_cheek", 150),
             _pair("close_b_l_eyelid", 210), _pair("close_t_l_eyelid", 80),
             _pair("raise_l_m_eyebrow", 25), _pair("raise_l_o_eyebrow", 25)),
    # 2 sadness: inner brows up and together, lids drooping, corners down, lower lip
    # pushed up and out, chin raised
    2: _both(_pair("raise_l_i_eyebrow", 190), _pair("raise_l_m_eyebrow", 30),
             _pair("raise_l_o_eyebrow", -70), _pair("squeeze_l_eyebrow", 60),
             _pair("close_t_l_eyelid", 300), _pair("close_b_l_eyelid", 40),
             _corners(-30, -250), {"raise_b_midlip_o": 110, "raise_b_lip_lm_o": 80,
             "raise_b_lip_rm_o": 80, "push_b_lip": 130, "depress_chin": 200}),
    # 3 anger: brows down and together, eyes wide, lips pressed thin, nostrils flared
    3: _both(_pair("raise_l_i_eyebrow", -190), _pair("raise_l_m_eyebrow", -120),
             _pair("raise_l_o_eyebrow", -20), _pair("squeeze_l_eyebrow", 150),
             _pair("close_t_l_eyelid", -170), _pair("close_b_l_eyelid", 150),
             {"lower_t_midlip_o": 130, "lower_t_lip_lm_o": 115, "lower_t_lip_rm_o": 115,
              "raise_b_midlip_o": 190, "raise_b_lip_lm_o": 165, "raise_b_lip_rm_o": 165,
              "raise_nose": 40, "depress_chin": 120}, _corners(-40, -70),
             _pair("stretch_l_nose", 130)),
    # 4 fear: brows raised and drawn together, eyes wide, mouth open and stretched
    4: _both(_pair("raise_l_i_eyebrow", 200), _pair("raise_l_m_eyebrow", 140),
             _pair("raise_l_o_eyebrow", 70), _pair("squeeze_l_eyebrow", 100),
             _pair("close_t_l_eyelid", -280), _pair("close_b_l_eyelid", -40),
             _jaw(340), _upper_lip(-100), _corners(150, -100)),
    # 5 disgust: upper lip raised (more on the left), nose wrinkled, lids narrowed
    5: _both({"lower_t_midlip": -200, "lower_t_lip_lm": -290, "lower_t_lip_rm": -160,
              "lower_t_midlip_o": -180, "lower_t_lip_lm_o": -270, "lower_t_lip_rm_o": -140,
              "raise_b_midlip_o": 60, "push_b_lip": 130, "raise_nose": 70,
              "raise_l_cornerlip": -40, "raise_r_cornerlip": -90},
             _pair("stretch_l_nose", 100), _pair("lift_l_cheek", 100),
             _pair("close_b_l_eyelid", 190), _pair("close_t_l_eyelid", 150),
             _pair("raise_l_i_eyebrow", -100), _pair("raise_l_m_eyebrow", -80),
             _pair("squeeze_l_eyebrow", 70)),
    # 6 surprise: brows high, upper lids up, jaw dropped, mouth a round O
    6: _both(_pair("raise_l_i_eyebrow", 230), _pair("raise_l_m_eyebrow", 260),
             _pair("raise_l_o_eyebrow", 200), _pair("close_t_l_eyelid", -300),
             _pair("close_b_l_eyelid", -60), _jaw(720), _upper_lip(-110), _corners(-110, 0)),
}


def shape_values(faps: dict) -> np.ndarray:
    """A 68-long array of FAP values (index = FAP number - 1) from {name: value}."""
    v = np.zeros(N_FAPS)
    for name, value in faps.items():
        v[FAP[name].number - 1] += value
    return v


def _axis_angle(R: np.ndarray) -> tuple:
    """Axis and angle of a rotation matrix (angle in [0, pi])."""
    angle = float(np.arccos(np.clip((np.trace(R) - 1) / 2, -1.0, 1.0)))
    axis = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    n = np.linalg.norm(axis)
    if n < 1e-12:
        return np.array([0.0, 0.0, 1.0]), 0.0
    return axis / n, angle


def high_level_tables(face, visemes: dict = None, expressions: dict = None,
                      tolerance: float = 1e-12) -> list:
    """FaceDefTables for FAP 1 (one per viseme) and FAP 2 (one per expression) from FAP
    combinations, evaluated with ``face``'s own low-level FAT (borders [0, 63])."""
    visemes = VISEME_FAPS if visemes is None else visemes
    expressions = EXPRESSION_FAPS if expressions is None else expressions
    keys = [(1, k) for k in sorted(visemes)] + [(2, k) for k in sorted(expressions)]
    rows = [shape_values((visemes if f == 1 else expressions)[k]) for f, k in keys]
    values = np.vstack([np.zeros(N_FAPS)] + rows)
    mask = np.ones_like(values, dtype=bool)
    mask[:, :2] = False
    play = face.play(FapStream(values, mask, fps=25.0))
    scale = max(float(np.abs(m.vertices).max()) for m in face.meshes.values() if len(m.vertices))
    out = []
    moved = {name: play.vertices(name) - play.vertices(name)[:1] for name in face.meshes}
    turns = {name: play.transform(name) for name in face.transforms}
    for f, (fap, select) in enumerate(keys, start=1):
        table = FaceDefTable(fap, select=select)
        for name, disp in moved.items():
            d = disp[f]
            idx = np.flatnonzero(np.abs(d).max(axis=1) > tolerance * scale)
            if len(idx):
                table.meshes.append(FaceDefMesh(name, [0.0, 63.0], idx, d[idx][:, None, :] / 63.0))
        for name, tr in turns.items():
            axis, angle = _axis_angle(tr["rotation"][f] @ tr["rotation"][0].T)
            if angle > 1e-12:
                table.transforms.append(FaceDefTransform(name, "rotation",
                                                         rotation=tuple(axis) + (angle / 63.0,)))
            dt = tr["translation"][f] - tr["translation"][0]
            if np.abs(dt).max() > tolerance * scale:
                table.transforms.append(FaceDefTransform(name, "translation",
                                                         translation=tuple(dt / 63.0)))
            ds = tr["scale"][f] - tr["scale"][0]
            if np.abs(ds).max() > 1e-12:
                table.transforms.append(FaceDefTransform(name, "scale", scale=tuple(ds / 63.0)))
        out.append(table)
    return out
