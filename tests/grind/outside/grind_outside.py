#!/usr/bin/python3
"""Back-lit frames of a cam being ground, written outside the grinding cell's code (issue 55).

Shares no code and no model with `mlp grind render`: its own profile (a cam of lines and arcs
as y = f(x), the material below), stock, wheel, optics and nuisances, so that `mlp grind
measure` is judged on frames it was not tuned to.

- Profile: a flat, a flank rising at a1, a convex nose R_n, a flank falling at a2, a concave
  arc R_c back to level, a flat; the previous pass left `stock` along the normal.
- The wheel: a round nose of radius R (1-6 mm) stepping along the profile; at each point its
  real centre is the NC's C plus an offset (the truth) and its radius less a wear.
- Optics: 10 x 10 sub-samples on boundary pixels, a Gaussian lens blur, a back light darker
  at the corners, veiling glare, photon and read noise, 8-bit.
- The seed's cell: both frames at the top of the stroke with the wheel 8 mm above focus: its
  shadow is the nose's disc seen through a cone of light (a disc-pillbox overlap), passing
  `shadow_pass` of the light at the disc's own edge region.
- Nuisances: a droplet thrown off somewhere in the after frame, a droplet on the freshly cut
  arc, a feather burr standing on the edge near the cut arc's end (truth marks the point
  spoiled). At first the burr was put on the wheel's arc, which floated it above the contour
  where the arc did not reach the material (seeds 5500-5523 and 8800-8823 were rendered so, at
  4e5cf5a); 8830-8853 are the fresh seeds of the mended renderer. A droplet on the wheel's arc
  spoils its point only within 0.12 mm of the material (the label only: the frames are the
  same; found on seed 9065, an R6 wheel gouging a corner, its circle 0.3 mm in the light).

Truth per point: the actual contour on the line C-Mi (first material along it from C), d, the
class against e, and for under-feed the wheel's error (direction, size).
"""
import json
import math
import os
import sys

import numpy as np

W, H, PX = 1024, 768, 0.005  # pixels and mm a pixel (the 1600 x 1200 scaled to fit)


class Cam:
    """A profile as y = f(x) over a fine grid: segments (line or arc) joined end to end."""

    def __init__(self, rng):
        a1 = math.radians(rng.uniform(35, 58))
        a2 = -math.radians(rng.uniform(20, 40))
        rn, rc = rng.uniform(0.6, 1.2), rng.uniform(2.0, 4.5)
        pts = [(0.0, 0.0), (rng.uniform(0.3, 0.7), 0.0)]
        # The flank rising at a1 then a convex nose from a1 down to a2, a flank at a2, a concave
        # arc from a2 back to 0, a flat: sampled as a polyline every 0.2 um.
        def line(angle, length):
            x, y = pts[-1]
            for s in np.linspace(0, length, max(2, int(length / 2e-4)))[1:]:
                pts.append((x + s * math.cos(angle), y + s * math.sin(angle)))

        def arc(a_from, a_to, radius, convex):
            x, y = pts[-1]
            # The centre is on the material side (convex: below the profile) or above (concave).
            nx, ny = (math.sin(a_from), -math.cos(a_from)) if convex else (-math.sin(a_from), math.cos(a_from))
            cx, cy = x + radius * nx, y + radius * ny
            steps = max(2, int(abs(a_to - a_from) * radius / 2e-4))
            for a in np.linspace(a_from, a_to, steps)[1:]:
                ux, uy = (-math.sin(a), math.cos(a)) if convex else (math.sin(a), -math.cos(a))
                pts.append((cx + radius * ux, cy + radius * uy))

        line(a1, rng.uniform(0.5, 0.9))
        arc(a1, a2, rn, True)
        line(a2, rng.uniform(0.4, 0.8))
        arc(a2, 0.0, rc, False)
        line(0.0, 0.6)
        p = np.array(pts)
        # Into the frame: the left flat at 1.0 mm from the left, the lowest point 0.8 mm up.
        p[:, 0] += 0.25
        p[:, 1] += 0.8 - p[:, 1].min()
        self.x, self.y = p[:, 0], p[:, 1]
        self.parameters = {"a1_deg": math.degrees(a1), "a2_deg": math.degrees(a2),
                           "nose_r_mm": rn, "concave_r_mm": rc}

    def normal_at(self, i):
        """The outward (up, away from the material) unit normal at sample i."""
        j0, j1 = max(0, i - 5), min(len(self.x) - 1, i + 5)
        tx, ty = self.x[j1] - self.x[j0], self.y[j1] - self.y[j0]
        t = math.hypot(tx, ty)
        return np.array([-ty / t, tx / t])

    def offset(self, stock):
        """The profile moved `stock` along its normal, as (x, y) samples."""
        tx, ty = np.gradient(self.x), np.gradient(self.y)
        t = np.hypot(tx, ty)
        return self.x - stock * ty / t, self.y + stock * tx / t

    def arclength(self):
        return np.concatenate([[0], np.cumsum(np.hypot(np.diff(self.x), np.diff(self.y)))])


def material(xs, ys, stock_curve, discs):
    """True where material: below the stock curve and outside every (cx, cy, r) disc."""
    sx, sy = stock_curve
    inside = ys < np.interp(xs, sx, sy)
    for cx, cy, r in discs:
        inside &= (xs - cx) ** 2 + (ys - cy) ** 2 >= r * r
    return inside


def coverage(stock_curve, discs, extra=None):
    """The material's share of each pixel: pixel centres, then 10 x 10 sub-samples where the
    boundary passes within 1.5 px (the stock curve's vertical distance, a disc's radius)."""
    u, v = np.meshgrid(np.arange(W), np.arange(H))
    xs, ys = u * PX, (H - 1 - v) * PX
    share = material(xs, ys, stock_curve, discs).astype(float)
    sx, sy = stock_curve
    near = np.abs(ys - np.interp(xs, sx, sy)) < 2.5 * PX
    for cx, cy, r in discs:
        near |= np.abs(np.hypot(xs - cx, ys - cy) - r) < 1.5 * PX
    if extra is not None:
        near |= extra["near"](xs, ys)
    iu, iv = np.nonzero(near.T)
    k = (np.arange(10) + 0.5) / 10 - 0.5
    du, dv = np.meshgrid(k, k)
    sub_x = (iu[:, None] + du.ravel()[None, :]) * PX
    sub_y = (H - 1 - iv[:, None] - dv.ravel()[None, :]) * PX
    inside = material(sub_x, sub_y, stock_curve, discs)
    if extra is not None:
        inside = extra["apply"](sub_x, sub_y, inside)
    share[iv, iu] = inside.mean(axis=1)
    if extra is not None:  # pixel centres elsewhere
        far = ~near
        share[far] = extra["apply"](xs[far], ys[far], share[far] > 0.5).astype(float)
    return share


def blur(img, sigma):
    r = int(math.ceil(3 * sigma))
    k = np.exp(-0.5 * (np.arange(-r, r + 1) / sigma) ** 2)
    k /= k.sum()
    pad = np.pad(img, r, mode="edge")
    out = np.apply_along_axis(lambda row: np.convolve(row, k, mode="valid"), 1, pad)
    return np.apply_along_axis(lambda col: np.convolve(col, k, mode="valid"), 0, out)


def box_blur(img, r):
    """Three box passes (about a Gaussian of sigma r): the glare's wide spread."""
    for _ in range(3):
        c = np.cumsum(np.pad(img, ((0, 0), (r + 1, r)), mode="edge"), axis=1)
        img = (c[:, 2 * r + 1:] - c[:, :-2 * r - 1]) / (2 * r + 1)
        c = np.cumsum(np.pad(img, ((r + 1, r), (0, 0)), mode="edge"), axis=0)
        img = (c[2 * r + 1:, :] - c[:-2 * r - 1, :]) / (2 * r + 1)
    return img


def wheel_shadow(cx, cy, r, cone_r):
    """The share of the light a defocused disc (centre, radius r) takes from each pixel: the
    overlap of the pillbox of radius cone_r round the pixel with the disc, over its area."""
    u, v = np.meshgrid(np.arange(W), np.arange(H))
    d = np.hypot(u * PX - cx, (H - 1 - v) * PX - cy)
    a, b = r, cone_r
    out = np.zeros_like(d)
    out[d <= a - b] = 1.0
    part = (d > abs(a - b)) & (d < a + b)
    dd = d[part]
    alpha = np.arccos(np.clip((dd ** 2 + b * b - a * a) / (2 * dd * b), -1, 1))
    beta = np.arccos(np.clip((dd ** 2 + a * a - b * b) / (2 * dd * a), -1, 1))
    area = b * b * alpha + a * a * beta - 0.5 * np.sqrt(np.clip(
        (-dd + a + b) * (dd + a - b) * (dd - a + b) * (dd + a + b), 0, None))
    out[part] = area / (math.pi * b * b)
    return out


def optics(share, rng, o, shadow=None):
    """Grey levels from the material's share: the back light (darker at the corners), the
    nose's defocused shadow, the lens blur, glare, photon and read noise."""
    u, v = np.meshgrid(np.arange(W), np.arange(H))
    rr = ((u - W / 2) ** 2 + (v - H / 2) ** 2) / ((W / 2) ** 2 + (H / 2) ** 2)
    light = o["bright"] * (1 - o["vignette"] * rr) * (1 - share)
    if shadow is not None:
        light = light * (1 - o["shadow_take"] * shadow)
    light = blur(light, o["blur_px"])
    light = (1 - o["glare"]) * light + o["glare"] * box_blur(light, 40)
    electrons = rng.poisson(np.clip(light, 0, None) * o["gain"]) / o["gain"]
    grey = o["dark"] + electrons + rng.normal(0, o["read_noise"], light.shape)
    return np.clip(np.round(grey), 0, 255).astype(np.uint8)


def write_pgm(path, img):
    with open(path, "wb") as f:
        f.write(b"P5\n%d %d\n255\n" % (img.shape[1], img.shape[0]))
        f.write(img.tobytes())


def first_material_on_line(c, mi, stock_curve, discs, extra_apply=None):
    """t [mm] from C along (Mi - C) / |Mi - C| to the first material (0.05 um steps)."""
    u = (mi - c) / np.linalg.norm(mi - c)
    ti = np.linalg.norm(mi - c)
    t = np.arange(max(0.0, ti - 0.6), ti + 0.6, 5e-5)
    xs, ys = c[0] + t * u[0], c[1] + t * u[1]
    inside = material(xs, ys, stock_curve, discs)
    if extra_apply is not None:
        inside = extra_apply(xs, ys, inside)
    if not inside.any():
        return None
    return float(t[np.argmax(inside)])


def make_case(seed):
    rng = np.random.default_rng(seed)
    cam = Cam(rng)
    r = float(rng.choice([1.0, 1.5, 2.0, 3.0, 4.0, 6.0]))
    stock = rng.uniform(0.03, 0.08)
    e = 0.005
    o = {"bright": rng.uniform(190, 225), "dark": rng.uniform(8, 25), "vignette": rng.uniform(0.04, 0.1),
         "glare": rng.uniform(0.01, 0.03), "blur_px": rng.uniform(0.7, 1.2), "gain": rng.uniform(20, 60),
         "read_noise": rng.uniform(0.8, 2.0), "shadow_take": rng.uniform(0.45, 0.6)}
    top_of_stroke = bool(rng.random() < 0.5)  # the seed's cell: the wheel's shadow in both frames
    cone_r = 8.0 * math.tan(math.radians(1.5))
    s = cam.arclength()
    # 8 points a step apart along the profile, from somewhere past the left flat.
    step = rng.uniform(0.05, 0.15)
    s0 = rng.uniform(0.3, max(0.31, s[-1] - 8 * step - 0.4))
    return {"seed": seed, "cam": cam, "r": r, "stock": stock, "e": e, "optics": o,
            "top_of_stroke": top_of_stroke, "cone_r": cone_r, "step": step, "s0": s0, "rng": rng}


def point_errors(rng):
    """The machine's error at a point: a class, then the wheel centre's offset (mm, in the
    normal's frame: along n, across) and the nose's wear."""
    kind = rng.choice(["good", "under", "under", "over", "wear"])
    if kind == "good":
        return kind, rng.uniform(-0.002, 0.002), rng.uniform(-0.002, 0.002), 0.0
    if kind == "under":  # the wheel held off: along +n, at an angle to it
        size, ang = rng.uniform(0.012, 0.03), math.radians(rng.uniform(-40, 40))
        return kind, size * math.cos(ang), size * math.sin(ang), 0.0
    if kind == "over":
        return kind, -rng.uniform(0.008, 0.02), rng.uniform(-0.003, 0.003), 0.0
    return kind, 0.0, 0.0, rng.uniform(0.008, 0.02)


def render_case(seed, out_dir):
    k = make_case(seed)
    cam, rng, r = k["cam"], k["rng"], k["r"]
    stock_curve = cam.offset(k["stock"])
    s = cam.arclength()
    discs, points, truth = [], [], []
    nuisance_point = int(rng.integers(0, 8)) if rng.random() < 0.6 else -1
    nuisance_kind = str(rng.choice(["droplet_on_arc", "burr", "droplet_off"]))
    prev_c = None
    for j in range(8):
        i = int(np.searchsorted(s, k["s0"] + j * k["step"]))
        mi = np.array([cam.x[i], cam.y[i]])
        n = cam.normal_at(i)
        c = mi + r * n
        kind, along, across, wear = point_errors(rng)
        t_hat = np.array([n[1], -n[0]])
        c_real = c + along * n + across * t_hat
        before_discs = list(discs)
        discs.append((c_real[0], c_real[1], r - wear))
        extra = None
        spoiled = False
        if j == nuisance_point:
            extra, spoiled = nuisance(nuisance_kind, rng, c_real, r - wear, mi, n,
                                      (stock_curve, discs))
        b_shadow = wheel_shadow(*(prev_c if prev_c is not None else c_real - 0.1 * t_hat), r, k["cone_r"]) \
            if k["top_of_stroke"] else None
        a_shadow = wheel_shadow(c_real[0], c_real[1], r, k["cone_r"]) if k["top_of_stroke"] else None
        before = optics(coverage(stock_curve, before_discs), rng, k["optics"], b_shadow)
        after = optics(coverage(stock_curve, discs, extra), rng, k["optics"], a_shadow)
        prev_c = (c_real[0], c_real[1])
        names = ("point_%02d_before.pgm" % j, "point_%02d_after.pgm" % j)
        write_pgm(os.path.join(out_dir, names[0]), before)
        write_pgm(os.path.join(out_dir, names[1]), after)
        t_mr = first_material_on_line(c, mi, stock_curve, discs,
                                      extra["apply"] if extra is not None else None)
        ti = r
        if t_mr is None:  # gouged past the search (a sharp concave corner): nothing to measure
            t_mr, d, feed = ti, float("nan"), "none"
        else:
            d = abs(t_mr - ti)
            feed = "good" if d <= k["e"] else ("under-feed" if t_mr < ti else "over-feed")
        err = c_real - c
        points.append({"before": names[0], "after": names[1], "c_mm": c.tolist(), "mi_mm": mi.tolist()})
        truth.append({"kind": kind, "feed": feed, "d_mm": d, "mr_mm": (c + t_mr * (mi - c) / ti).tolist(),
                      "offset_mm": err.tolist(), "wear_mm": wear, "normal": n.tolist(),
                      "error_deg_from_normal": math.degrees(math.atan2(across, along)) if kind == "under" else None,
                      "error_mm": math.hypot(along, across) if kind == "under" else None,
                      "spoiled": spoiled, "nuisance": nuisance_kind if j == nuisance_point else None})
    job = {"format": "mlprobe-grind/1",
           "camera": {"width_px": W, "height_px": H, "mm_per_px": PX, "origin_x_mm": 0.0,
                      "origin_y_mm": (H - 1) * PX},
           "wheel_radius_mm": r, "limit_mm": k["e"], "stock_mm": k["stock"],
           "profile": polyline_profile(cam), "points": points}
    with open(os.path.join(out_dir, "job.json"), "w") as f:
        json.dump(job, f, indent=1)
    with open(os.path.join(out_dir, "outside_truth.json"), "w") as f:
        json.dump({"seed": seed, "wheel_radius_mm": r, "top_of_stroke": k["top_of_stroke"],
                   "profile": cam.parameters, "points": truth}, f, indent=1)


def nuisance(kind, rng, c_real, r_real, mi, n, surface):
    """A droplet or a burr in the after frame: (extra for coverage, whether it spoils the point)."""
    if kind == "droplet_off":  # thrown off between frames, somewhere away from the point
        cx, cy = rng.uniform(0.5, W * PX - 0.5), rng.uniform(H * PX * 0.6, H * PX - 0.3)
        rad = rng.uniform(0.02, 0.05)
        spoils = False
    elif kind == "droplet_on_arc":  # sitting on the freshly cut arc near Mi
        ang = rng.uniform(-0.08, 0.08)
        p = c_real - r_real * np.array([n[0] * math.cos(ang) - n[1] * math.sin(ang),
                                        n[0] * math.sin(ang) + n[1] * math.cos(ang)])
        rad = rng.uniform(0.01, 0.03)
        cx, cy = p[0] + 0.7 * rad * n[0], p[1] + 0.7 * rad * n[1]
        # On the wheel's circle, which is the cut arc only where the wheel reached the material:
        # an R6 wheel in a 57 deg corner leaves its circle 0.3 mm in the light (seed 9065), the
        # droplet floating there spoils no point. Nearer the material than the tallest burr
        # stands (0.12 mm) it is on the edge as far as any reading of the edge goes (droplets
        # 3.5-8.5 px off the edge, seeds 5507, 5509, 5513, take the edge searches' falls).
        a = np.linspace(0, 2 * math.pi, 64, endpoint=False)
        reach = rad + 0.12
        spoils = bool(material(cx + reach * np.cos(a), cy + reach * np.sin(a),
                               surface[0], surface[1]).any())
    else:  # a feather burr: a 7 um sliver standing on the cut edge near the arc's end, 60-120 um
        ang = 0.12 + rng.uniform(0, 0.05)
        t_hat = np.array([n[1], -n[0]])
        # Its foot on the material's edge (the first material from the wheel's centre that way),
        # 1 um into it so that the sliver joins the edge.
        way = -(math.cos(ang) * n + math.sin(ang) * t_hat)
        t = np.arange(0.0, r_real + 0.6, 2e-4)
        xs, ys = c_real[0] + t * way[0], c_real[1] + t * way[1]
        inside = material(xs, ys, surface[0], surface[1])
        foot = t[np.argmax(inside)] if inside.any() else r_real
        base = c_real + (foot + 0.001) * way
        length, thick = rng.uniform(0.06, 0.12), 0.007

        def near_b(xs, ys):
            q = np.stack([xs - base[0], ys - base[1]], -1)
            a, b = q @ n, q @ t_hat
            return (a > -0.01) & (a < length + 0.01) & (np.abs(b) < thick + 0.01)

        def apply_b(xs, ys, inside):
            q = np.stack([xs - base[0], ys - base[1]], -1)
            a, b = q @ n, q @ t_hat
            return inside | ((a > 0) & (a < length) & (np.abs(b) < thick / 2))

        # Where that way meets no material within reach the sliver floats off the contour (an
        # R6 wheel on a flank curving away: seed 5539): in the frame, not on the point.
        return {"near": near_b, "apply": apply_b}, bool(inside.any())

    def near_d(xs, ys):
        return np.abs(np.hypot(xs - cx, ys - cy) - rad) < 2 * PX

    def apply_d(xs, ys, inside):
        return inside | ((xs - cx) ** 2 + (ys - cy) ** 2 < rad * rad)

    return {"near": near_d, "apply": apply_d}, spoils


def polyline_profile(cam):
    """The nominal as line segments every ~20 um (the job's format takes lines and arcs)."""
    idx = np.unique(np.concatenate([np.arange(0, len(cam.x), 100), [len(cam.x) - 1]]))
    return [{"start": [float(cam.x[a]), float(cam.y[a])], "end": [float(cam.x[b]), float(cam.y[b])]}
            for a, b in zip(idx[:-1], idx[1:])]


if __name__ == "__main__":
    os.makedirs(sys.argv[2], exist_ok=True)
    render_case(int(sys.argv[1]), sys.argv[2])
