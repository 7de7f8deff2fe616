#!/usr/bin/python3
"""An outside tool renderer (issue 51): back-lit shadow images of cutting tools as they are
ground, written without the product's code or its tool model.

The tool is a solid in a right-handed frame (x, y, z), z up the spindle, 0 at the nominal tip.
Each tooth has a cutting edge on a helix (either hand) and, behind it, its back: a land with
its primary relief, then a secondary relief (end mills) or a drill's margin and its body
clearance, to the heel; then the flute down to the web (a cylinder). The end clips every
tooth radially: a drill's point cone, a corner radius, a ball. A chip is a sphere stuck to an
edge. The spindle turns M3 (clockwise seen from above: the angle about +z falls) or M4.
The camera is orthographic, on the -x side looking along +x: image right is -y, image up +z,
tilted by its pitch (what is farther looks lower) and rolled about its view; a radial
distortion about the image centre, a Gaussian blur, a back light darker at the corners,
photon and read noise, 8 bits. Pixels by 3 x 3 samples each.

Frozen seeds: tools 5100.. tuned on, 9100.. reported fresh (docs/TOOLCAM.md).
From seed 20000 on (the second corpus, frozen 2026-11-29 before the product read any of it:
20000.. tuned on, 29000.. fresh) each tool also has: a lens decentred (its principal point up
to 30 px off the image's centre, Brown's tangential terms up to 3e-4), a strobe that fires
late or early (0.5 deg RMS) with each image's angle measured (an encoder's angle_deg, or
time_us since the index pulse), pulses of 3-6 us (the image as bright as its pulse is long,
the tool turning during it); and taps (ISO metric coarse threads, a chamfer per land).
"""
import json
import math
import os

import numpy as np

W, H = 1024, 768
SUB = 3  # samples across a pixel each way


def _drops(tooth, psi):
    """Radius below the edge's at angle psi [rad] behind it along the tooth's back."""
    r = tooth["r"]
    s = r * psi
    w, a1 = tooth["land_mm"], math.radians(tooth["relief_deg"])
    drop = np.where(s <= w, s * math.tan(a1), w * math.tan(a1))
    if tooth["body_clearance_mm"] > 0:
        drop = np.where(s <= w, drop, tooth["body_clearance_mm"])
    else:
        drop = np.where(s <= w, drop, drop + (s - w) * math.tan(math.radians(tooth["relief2_deg"])))
    return drop


def thread_depth(spec, z, phi):
    """A tap's thread: how far under the crest at height z and physical angle phi [rad] about
    +z (ISO 68-1's basic profile, 5H/8 deep, crest flat P/8, root flat P/4). A right-hand
    thread's crest rises turning counterclockwise seen from above: z0 + P phi / 2 pi."""
    p = spec.get("pitch_mm", 0.0)
    if p <= 0:
        return 0.0
    t = (z - spec["thread_z0_mm"] - p * phi / (2 * math.pi)) / p
    a = np.abs(t - np.round(t))  # pitches from the nearest crest's middle
    return p * 0.54127 * np.clip((a - 1 / 16) / (3 / 8 - 1 / 16), 0, 1)


def _end_limit(spec, tooth, z):
    """How far out the tooth reaches at height z (its end's shape); nan below its tip."""
    t = z - tooth["tip_mm"]
    out = np.full_like(z, np.inf)
    if spec["point_deg"] > 0:
        out = (spec.get("tip_d_mm", 0.0) / 2 +
               np.maximum(t, 0) * math.tan(math.radians(spec["point_deg"] / 2)))
    else:
        rc = tooth["corner_mm"]
        if rc > 0:
            q = np.clip(rc - t, 0, rc)
            out = np.where(t < rc, tooth["r"] - rc + np.sqrt(np.maximum(rc * rc - q * q, 0)),
                           np.inf)
    return np.where(t < 0, np.nan, out)


def _back_points(spec, z, tooth, heel, edge_angle, trail, lim, want_max):
    """The back's points near its extreme across Y at each height: a 0.5 deg grid over the
    whole back, then a 0.004 deg grid over +-0.6 deg round the best of it (and both ends)."""
    coarse = np.linspace(0, heel, max(int(math.degrees(heel) / 0.5), 2) + 1)
    r = np.minimum(tooth["r"] - _drops(tooth, coarse)[None, :], lim)
    r = r - thread_depth(spec, z[:, None], edge_angle + trail * coarse[None, :])
    Y = -r * np.sin(edge_angle + trail * coarse[None, :])
    Y = np.where(np.isnan(Y), -np.inf if want_max else np.inf, Y)
    i = np.argmax(Y, axis=1) if want_max else np.argmin(Y, axis=1)
    fine = coarse[i][:, None] + np.radians(np.linspace(-0.6, 0.6, 301))[None, :]
    fine = np.clip(fine, 0, heel)
    fine = np.concatenate([fine, np.zeros((len(i), 1)), np.full((len(i), 1), heel)], axis=1)
    r = np.minimum(tooth["r"] - _drops(tooth, fine), lim)
    r = r - thread_depth(spec, z[:, None], edge_angle + trail * fine)
    return r, edge_angle + trail * fine


def extents(spec, theta_rot, z):
    """The shadow across image-right Y = -y at heights z with the tool turned theta_rot (its
    physical angle about +z): (Ymin, Ymax, depth at Ymin, depth at Ymax); nan where empty."""
    n = len(spec["teeth"])
    ymin = np.full(z.shape, np.inf)
    ymax = np.full(z.shape, -np.inf)
    xmin, xmax = np.zeros(z.shape), np.zeros(z.shape)
    hand = 1.0 if spec["helix_hand"] == "right" else -1.0
    trail = 1.0 if spec["cut"] == "right" else -1.0
    r_nom = spec["d_mm"] / 2

    def take(x, yy, ok):
        nonlocal ymin, ymax, xmin, xmax
        Y = -yy
        Y = np.where(ok, Y, np.nan)
        lo_i = np.nanargmin(np.where(np.isnan(Y), np.inf, Y), axis=1)
        hi_i = np.nanargmax(np.where(np.isnan(Y), -np.inf, Y), axis=1)
        rows = np.arange(Y.shape[0])
        lo, hi = Y[rows, lo_i], Y[rows, hi_i]
        upd = ~np.isnan(lo) & (lo < ymin)
        ymin, xmin = np.where(upd, lo, ymin), np.where(upd, x[rows, lo_i], xmin)
        upd = ~np.isnan(hi) & (hi > ymax)
        ymax, xmax = np.where(upd, hi, ymax), np.where(upd, x[rows, hi_i], xmax)

    for k, tooth in enumerate(spec["teeth"]):
        heel = math.radians(spec["heel_deg"])
        lim = _end_limit(spec, tooth, z)[:, None]
        edge_angle = (theta_rot + tooth["angle"] +
                      hand * z * math.tan(math.radians(spec["helix_deg"])) / r_nom)[:, None]
        for want_max in (True, False):
            r_back, ang = _back_points(spec, z, tooth, heel, edge_angle, trail, lim, want_max)
            ok = ~np.isnan(lim) & (r_back > 0)
            take(r_back * np.cos(ang), r_back * np.sin(ang), ok)
        # the rake face: a radial line at the edge, and the heel's drop to the web
        r_heel = tooth["r"] - float(_drops(tooth, np.array([heel]))[0])
        for a, top in ((edge_angle, tooth["r"]), (edge_angle + trail * heel, r_heel)):
            rr = np.minimum(np.linspace(spec["core"] * r_nom, top, 4)[None, :], lim)
            rr = np.minimum(rr, top - thread_depth(spec, z[:, None], a))
            okr = ~np.isnan(lim) & (rr > 0)
            take(rr * np.cos(a), rr * np.sin(a), np.broadcast_to(okr, rr.shape))
    # the web: a cylinder, ending with the longest tooth (inside a point's cone)
    lowest = min(t["tip_mm"] for t in spec["teeth"])
    web = np.full(z.shape, spec["core"] * r_nom)
    if spec["point_deg"] > 0:
        web = np.minimum(web, spec.get("tip_d_mm", 0.0) / 2 +
                         np.maximum(z - lowest, 0) * math.tan(math.radians(spec["point_deg"] / 2)))
    web = np.where(z >= lowest, web, np.nan)
    has = ~np.isnan(web)
    ymin = np.where(has, np.minimum(ymin, -web), ymin)
    ymax = np.where(has, np.maximum(ymax, web), ymax)
    for chip in spec["chips"]:
        cz, cr = chip["z_mm"], chip["radius_mm"]
        t = spec["teeth"][chip["tooth"]]
        a = theta_rot + t["angle"] + hand * cz * math.tan(math.radians(spec["helix_deg"])) / r_nom
        rho = t["r"] + 0.6 * cr  # stuck on the edge, most of it outside
        cx, cY = rho * math.cos(a), -rho * math.sin(a)
        half = np.sqrt(np.maximum(cr * cr - (z - cz) ** 2, 0))
        on = half > 0
        touch = on & (cY - half <= ymax) & (cY + half >= ymin)
        grow = touch & (cY + half > ymax)
        ymax, xmax = np.where(grow, cY + half, ymax), np.where(grow, cx, xmax)
        grow = touch & (cY - half < ymin)
        ymin, xmin = np.where(grow, cY - half, ymin), np.where(grow, cx, xmin)
    empty = ~np.isfinite(ymax)
    return (np.where(empty, np.nan, ymin), np.where(empty, np.nan, ymax), xmin, xmax)


def _blur(img, sigma):
    k = np.arange(-4, 5)
    g = np.exp(-0.5 * (k / sigma) ** 2)
    g /= g.sum()
    pad = np.pad(img, 4, mode="edge")
    rows = sum(g[i] * pad[:, i:i + img.shape[1]] for i in range(9))
    return sum(g[i] * rows[i:i + img.shape[0], :] for i in range(9))


def _ideal(cam, u, v):
    """Sensor points (u, v) back to where an ideal lens puts them: Brown's model about the
    principal point, distorted = ideal (1 + k1 rho^2) + tangential(ideal), rho in units of
    the image's half-diagonal, undone by fixed-point iteration."""
    cx, cy = (W - 1) / 2, (H - 1) / 2
    corner = math.sqrt(cx * cx + cy * cy)
    pu, pv = cam.get("principal", (cx, cy))
    p1, p2 = cam.get("p1", 0.0), cam.get("p2", 0.0)
    du, dv = (u - pu) / corner, (v - pv) / corner
    x, y = du.copy(), dv.copy()
    for _ in range(6):
        r2 = x * x + y * y
        tx = 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
        ty = p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
        f = 1 + cam["k1"] * r2
        x, y = (du - tx) / f, (dv - ty) / f
    return pu + x * corner, pv + y * corner


def render(spec, cam, theta_rot, rng, pulse_rad=0.0, gain=1.0):
    """One 8-bit image of the tool turned theta_rot (the pulse's middle), the tool turning
    pulse_rad during the pulse (three instants averaged), the light's range times gain."""
    if pulse_rad > 0:
        thetas = [theta_rot + pulse_rad * f for f in (-1 / 3, 0.0, 1 / 3)]
        shares = [_dark_share(spec, cam, t) for t in thetas]
        return _expose(cam, sum(shares) / len(shares), rng, gain)
    return _expose(cam, _dark_share(spec, cam, theta_rot), rng, gain)


def _dark_share(spec, cam, theta_rot):
    """Each pixel's share of shadow with the tool turned theta_rot."""
    s = cam["mm_per_px"]
    # the heights a ray meets, from below the tip to above the field (pitch: depth x moves
    # what the camera sees by -x tan(pitch))
    z = np.arange(-0.05, (H + 20) * s * 1.02 + 0.05, 0.002)
    ymin, ymax, xlo, xhi = extents(spec, theta_rot, z)
    tp = math.tan(math.radians(cam["pitch_deg"]))
    hv_lo, hv_hi = z - xlo * tp, z - xhi * tp

    def shaded(u, v):
        """Whether the rays through sensor points (u, v) meet the tool."""
        iu, iv = _ideal(cam, u, v)
        pu, pv = iu - cam["axis_u_px"], cam["tip_v_px"] - iv
        a = math.radians(cam["roll_deg"])
        # roll turns the tool's image about (axis_u, tip_v): its axis leans right going down
        Y = (math.cos(a) * pu + math.sin(a) * pv) * s
        hv = (math.cos(a) * pv - math.sin(a) * pu) * s
        lo = np.interp(hv, hv_lo, np.nan_to_num(ymin, nan=1e9), left=1e9, right=1e9)
        hi = np.interp(hv, hv_hi, np.nan_to_num(ymax, nan=-1e9), left=-1e9, right=-1e9)
        return (Y >= lo) & (Y <= hi)

    vv, uu = np.mgrid[0:H, 0:W].astype(float)
    centre = shaded(uu, vv)
    pad = np.pad(centre, 1, mode="edge")
    mixed = np.zeros_like(centre)
    for dy in range(3):
        for dx in range(3):
            mixed |= pad[dy:dy + H, dx:dx + W] != centre
    dark_share = centre.astype(float)
    off = (np.arange(SUB) + 0.5) / SUB - 0.5
    mv, mu = np.nonzero(mixed)
    su = mu[:, None, None] + off[None, None, :]
    sv = mv[:, None, None] + off[None, :, None]
    dark_share[mv, mu] = shaded(su + 0 * sv, sv + 0 * su).mean(axis=(1, 2))
    return dark_share


def _expose(cam, dark_share, rng, exposure):
    """The image of a shadow share: optics' blur, the back light's fall-off, its range times
    the exposure, photon and read noise, 8 bits."""
    cx, cy = (W - 1) / 2, (H - 1) / 2
    corner2 = cx * cx + cy * cy
    light = _blur(1.0 - dark_share, cam["psf_px"])
    rr = ((np.arange(W)[None, :] - cx) ** 2 + (np.arange(H)[:, None] - cy) ** 2) / corner2
    gain = 1.0 - cam["vignette"] * rr
    grey = cam["dark"] + (cam["bright"] - cam["dark"]) * exposure * light * gain
    electrons = rng.poisson(np.maximum(grey, 0) * cam["e_per_grey"]) / cam["e_per_grey"]
    grey = electrons + rng.normal(0, cam["read_noise"], grey.shape)
    return np.clip(np.round(grey), 0, 255).astype(np.uint8)


def write_pgm(path, img):
    with open(path, "wb") as f:
        f.write(b"P5\n%d %d\n255\n" % (img.shape[1], img.shape[0]))
        f.write(img.tobytes())


FAMILIES = ("drill", "endmill", "endmill", "ballnose", "torus")
FAMILIES2 = ("drill", "endmill", "tap", "ballnose", "torus")
SECOND = 20000  # the second corpus' first seed
# ISO 261 coarse threads: (diameter, pitch) [mm]
TAPS = ((3.0, 0.5), (4.0, 0.7), (5.0, 0.8), (6.0, 1.0), (8.0, 1.25), (10.0, 1.5), (12.0, 1.75))


def make_spec(seed):
    """A tool as ground, its camera, its series: all from the seed."""
    rng = np.random.default_rng(seed)
    fam = (FAMILIES2 if seed >= SECOND else FAMILIES)[seed % len(FAMILIES)]
    spec = {"seed": seed, "family": fam, "point_deg": 0.0, "chips": []}
    if fam == "tap":
        corner = _tap(spec, rng)
        d, n, back = spec["d_mm"], spec["n"], spec["back"]
    elif fam == "drill":
        d = float(rng.choice([0.5, 0.8, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 10.0, 12.0]))
        n = 2
        spec.update(point_deg=float(rng.choice([118.0, 130.0, 140.0])),
                    helix_deg=float(rng.uniform(25, 35)), core=float(rng.uniform(0.15, 0.25)))
        land = float(rng.uniform(0.06, 0.12)) * d ** 0.7
        back = dict(land_mm=land, relief_deg=0.0, relief2_deg=0.0,
                    body_clearance_mm=float(rng.uniform(0.02, 0.05)) * d ** 0.8)
        spec["heel_deg"] = float(rng.uniform(70, 100))
        corner = 0.0
    else:
        d = float(rng.choice([2.0, 3.0, 4.0, 6.0, 8.0, 10.0, 12.0, 16.0]))
        n = int(rng.choice([2, 3, 4, 4, 5, 6])) if d >= 4 else int(rng.choice([2, 3, 4]))
        spec.update(helix_deg=float(rng.choice([0.0, 30.0, 35.0, 40.0, 45.0]) if fam == "endmill"
                                    else rng.choice([25.0, 30.0])),
                    core=float(rng.uniform(0.5, 0.65)))
        land = float(rng.uniform(0.03, 0.06)) * d ** 0.6
        back = dict(land_mm=land, relief_deg=float(rng.uniform(6, 12)),
                    relief2_deg=float(rng.uniform(15, 25)), body_clearance_mm=0.0)
        spec["heel_deg"] = float(0.5 * 360 / n)
        corner = {"endmill": float(rng.choice([0.0, 0.0, 0.2, 0.5])), "ballnose": d / 2,
                  "torus": float(rng.choice([0.5, 1.0])) if d >= 4 else 0.3}[fam]
    spec["d_mm"] = d
    spec["helix_hand"] = "left" if rng.uniform() < 0.2 and fam != "tap" else "right"
    spec["cut"] = "left" if rng.uniform() < 0.15 else "right"
    spec["spindle"] = "M4" if rng.uniform() < 0.4 else "M3"
    spec["corner_mm"] = corner
    small = d < 3
    tir = 2e-3 if small else 5e-3
    teeth = []
    for k in range(n):
        t = dict(back)
        t.update(angle=2 * math.pi * k / n, r=d / 2 + float(rng.uniform(-tir, tir)),
                 tip_mm=float(rng.uniform(-3e-3, 3e-3)), corner_mm=corner)
        teeth.append(t)
    spec["teeth"] = teeth
    spec["worn_corner"] = None
    if fam == "endmill" and corner == 0.0 and rng.uniform() < 0.4:
        k = int(rng.integers(n))
        teeth[k]["corner_mm"] = float(rng.uniform(0.03, 0.06))
        spec["worn_corner"] = {"tooth": k, "radius_mm": teeth[k]["corner_mm"]}
    if rng.uniform() < 0.3:
        spec["chips"].append({"tooth": int(rng.integers(n)), "z_mm": float(rng.uniform(0.6, 1.6)),
                              "radius_mm": float(rng.uniform(0.012, 0.03))})
    spec["flute_length_mm"] = max(3.0, 2.0 * d)
    spec["length_mm"] = 30.0 + 2 * d
    # the camera: small tools wholly in view, larger ones with the axis left of the field
    s = 0.002 if d <= 1.6 else 0.0035 if d <= 3.0 else 0.004
    end = corner if spec["point_deg"] == 0 else ((d - spec.get("tip_d_mm", 0.0)) / 2 /
                                                 math.tan(math.radians(spec["point_deg"] / 2)))
    s = max(s, (end + 1.7) / 540)  # the end's shape and 1.7 mm of flank above it in view
    axis_u = (W - 1) / 2 if d / s < 0.85 * W else 620 - (d / 2) / s
    spec["camera"] = dict(mm_per_px=s, axis_u_px=float(axis_u + rng.uniform(-3, 3)),
                          tip_v_px=float(560 + rng.uniform(-5, 5)),
                          roll_deg=float(rng.uniform(-0.15, 0.15)),
                          pitch_deg=float(rng.uniform(-0.05, 0.05)),
                          k1=float(rng.uniform(0.0, 0.0008)), psf_px=float(rng.uniform(0.6, 0.9)),
                          vignette=0.05, bright=215.0, dark=22.0, e_per_grey=40.0,
                          read_noise=1.2)
    spec["positions"] = 40
    spec["start_rad"] = float(rng.uniform(0, 2 * math.pi))
    if seed >= SECOND:
        _second_corpus(spec, np.random.default_rng(seed + 424242))
    return spec


def _tap(spec, rng):
    """A machine tap: straight or spiral flutes, lands carrying the thread with a little
    relief, a chamfer ground on each land from a tip under the minor diameter."""
    d, pitch = TAPS[int(rng.integers(len(TAPS)))]
    n = 3 if d < 8 else 4
    depth = 0.54127 * pitch
    tip_d = d - 2 * depth * float(rng.uniform(1.02, 1.15))
    chamfer = float(rng.uniform(2.0, 3.5)) * pitch
    spec.update(d_mm=d, n=n, pitch_mm=pitch, thread_z0_mm=float(rng.uniform(0, pitch)),
                tip_d_mm=tip_d,
                point_deg=2 * math.degrees(math.atan((d - tip_d) / 2 / chamfer)),
                helix_deg=float(rng.choice([0.0, 0.0, 15.0])),
                core=float(rng.uniform(0.45, 0.55)), heel_deg=float(0.5 * 360 / n))
    spec["back"] = dict(land_mm=float(rng.uniform(0.25, 0.4)) * math.pi * d / n,
                        relief_deg=float(rng.uniform(1, 3)),
                        relief2_deg=float(rng.uniform(15, 25)), body_clearance_mm=0.0)
    return 0.0


def _second_corpus(spec, rng):
    """The second corpus' camera and strobe (the module's text)."""
    cam = spec["camera"]
    cam["principal"] = ((W - 1) / 2 + float(rng.uniform(-30, 30)),
                        (H - 1) / 2 + float(rng.uniform(-30, 30)))
    cam["p1"], cam["p2"] = float(rng.uniform(-3e-4, 3e-4)), float(rng.uniform(-3e-4, 3e-4))
    n = spec["positions"]
    spec["late_deg"] = [float(np.clip(rng.normal(0, 0.5), -1.5, 1.5)) for _ in range(n)]
    spec["pulse_us"] = [float(rng.uniform(3, 6)) for _ in range(n)]
    spec["angle_by"] = "encoder" if rng.uniform() < 0.5 else "time"


def product_tool(spec):
    """The product's tool description of the tool as specified (docs/TOOLCAM.md's fields)."""
    t = spec["teeth"][0]
    tool = {"format": "mlprobe-tool/1", "id": "outside-%d" % spec["seed"],
            "diameter_mm": spec["d_mm"], "length_mm": spec["length_mm"],
            "flutes": len(spec["teeth"]), "helix_deg": spec["helix_deg"],
            "helix_hand": spec["helix_hand"], "cut": spec["cut"],
            "flute_length_mm": spec["flute_length_mm"], "core_ratio": spec["core"],
            "land_width_mm": t["land_mm"], "land_relief_deg": t["relief_deg"],
            "heel_deg": spec["heel_deg"], "wear_limit_mm": 0.01}
    if t["body_clearance_mm"] > 0:
        tool["body_clearance_mm"] = t["body_clearance_mm"]
    else:
        tool["clearance_relief_deg"] = t["relief2_deg"]
    if spec.get("pitch_mm", 0) > 0:
        tool["thread_pitch_mm"] = spec["pitch_mm"]
    if spec.get("tip_d_mm", 0) > 0:
        tool["tip_diameter_mm"] = spec["tip_d_mm"]
    if spec["point_deg"] > 0:
        tool["point_angle_deg"] = spec["point_deg"]
    else:
        tool["corner_radius_mm"] = spec["corner_mm"]
    return tool


def truth(spec):
    teeth = spec["teeth"]
    lowest = min(t["tip_mm"] for t in teeth)
    return {"seed": spec["seed"], "family": spec["family"], "d_mm": spec["d_mm"],
            "spindle": spec["spindle"], "helix_hand": spec["helix_hand"], "cut": spec["cut"],
            "radii_mm": [t["r"] for t in teeth], "tips_mm": [t["tip_mm"] for t in teeth],
            "length_mm": spec["length_mm"] - lowest, "worn_corner": spec["worn_corner"],
            "chips": spec["chips"],
            "unmeasurable": ("a tap's land carries its thread round the back: not modelled"
                             if spec["family"] == "tap" else None)}


def write_case(spec, folder):
    """Images, the product's manifest, tool file and the truth into folder."""
    os.makedirs(folder, exist_ok=True)
    rng = np.random.default_rng(spec["seed"] + 1000003)
    n = spec["positions"]
    cam = spec["camera"]
    # a free-running camera: 7 positions on per image (coprime with 40)
    order = [(7 * i) % n for i in range(n)]
    sense = -1.0 if spec["spindle"] == "M3" else 1.0
    images = []
    rpm = 6000.0
    deg_per_us = rpm / 60 * 360 * 1e-6
    for i, p in enumerate(order):
        entry = {"file": "img_%03d.pgm" % i, "position": p}
        turned_deg = 360.0 * p / n
        pulse_rad, gain = 0.0, 1.0
        if "late_deg" in spec:  # the second corpus: the strobe late, its angle measured
            turned_deg += spec["late_deg"][p]
            if spec["angle_by"] == "encoder":
                entry["angle_deg"] = round(turned_deg + float(rng.normal(0, 0.003)), 4)
            else:
                entry["time_us"] = round(turned_deg / deg_per_us, 1)
            entry["pulse_width_us"] = round(spec["pulse_us"][p], 2)
            pulse_rad = math.radians(spec["pulse_us"][p] * deg_per_us)
            gain = spec["pulse_us"][p] / 6.0
        theta = spec["start_rad"] + sense * math.radians(turned_deg)
        write_pgm(os.path.join(folder, entry["file"]), render(spec, cam, theta, rng, pulse_rad, gain))
        images.append(entry)
    camera = {"width_px": W, "height_px": H, "mm_per_px": cam["mm_per_px"],
              "axis_u_px": cam["axis_u_px"], "tip_v_px": cam["tip_v_px"],
              "distortion_k1": cam["k1"], "roll_deg": cam["roll_deg"],
              "pitch_deg": cam["pitch_deg"]}
    if "principal" in cam:
        camera.update(principal_u_px=cam["principal"][0], principal_v_px=cam["principal"][1],
                      distortion_p1=cam["p1"], distortion_p2=cam["p2"])
    manifest = {"format": "mlprobe-tool-images/1",
                "camera": camera,
                "strobe": {"rpm": rpm, "positions": n, "pulse_width_us": 0.0},
                "spindle": {"y_mm": 0.0, "z_mm": 0.0, "direction": spec["spindle"]},
                "images": images}
    with open(os.path.join(folder, "images.json"), "w") as f:
        json.dump(manifest, f, indent=1)
    with open(os.path.join(folder, "tool.json"), "w") as f:
        json.dump(product_tool(spec), f, indent=1)
    with open(os.path.join(folder, "truth.json"), "w") as f:
        json.dump(truth(spec), f, indent=1)


if __name__ == "__main__":
    import sys
    sd = int(sys.argv[1])
    write_case(make_spec(sd), sys.argv[2])
