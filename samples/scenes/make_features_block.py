#!/usr/bin/env python3
"""Writes features_block.json: a block with one of each feature a measure job knows, made a
little off its drawing (sizes a few micrometres over or under, positions shifted, a chamfer a
little steep), with the inspection plan a macro would send ("inspection": each feature's
request without captures) and the truth beside it. The host plans the captures from the
nominals (op "plan"); the scene's own capture list only holds a look at the top face.

Block 200 x 100 x 40 mm, top face z = 0 in block coordinates, placed level at MCS
(200, 100, -300). Elliptical features have no solid in the virtual probe's scenes; they are
tested on synthetic points (tests/host/composite_test.cc). Pure Python; the JSON it wrote is
committed beside it."""
import json
import math

OFFSET = (200.0, 100.0, -300.0)


def mcs(x, y, z):
    return [round(OFFSET[0] + x, 9), round(OFFSET[1] + y, 9), round(OFFSET[2] + z, 9)]


def box(lo, hi):
    return {"box": {"min": mcs(*lo), "max": mcs(*hi)}}


def cylinder(x, y, z, radius, length, axis=(0, 0, 1)):
    return {"cylinder": {"base": mcs(x, y, z), "axis": list(axis), "radius": radius,
                         "length": length}}


# Rectangular pocket: drawing 60 x 40 at (40, 30), 15 deep; made 60.020 x 39.992, 0.012 / -0.008
# off centre.
POCKET = dict(cx=40.012, cy=29.992, sx=60.020, sy=39.992, depth=15.0)
# Boss on the top face: drawing D30 at (120, 30), 15 high; made D29.988 at (120.006, 30.004).
BOSS = dict(cx=120.006, cy=30.004, d=29.988, height=15.0)
# Slot open to the back edge: drawing 16 wide centred x = 88, 10 deep; made 16.014 at 88.003.
SLOT = dict(cx=88.003, w=16.014, y0=55.0, depth=10.0)
# Shelf along the right of the back half: drawing 10 below the top; made 10.006.
SHELF = dict(x0=140.0, y0=55.0, depth=10.006)
# Four D8 holes on a 30 mm bolt circle round (35, 78), 12 deep; made on 30.008 round
# (35.004, 77.997), the pattern turned 0.15 deg.
PCD = dict(cx=35.004, cy=77.997, d=30.008, turn_deg=0.15, hole_d=8.0, depth=12.0)
# Chamfer along the front edge: drawing 60 deg from the top face, 4 mm wide on top; made 60.02.
CHAMFER = dict(angle_deg=60.02, top_width=4.0)
# A crown: a cylinder R 50 along X, its top 3 mm over the top face at y = 35, x 165..195;
# made 4 um proud (R 50.004 on the same axis).
CROWN = dict(x0=165.0, length=30.0, cy=35.0, axis_z=-47.0, r=50.0, proud=0.004)


# The right wall (x = 200 on the drawing), under the top face's right edge: made 8 um proud at
# y = 0 and turned 0.02 deg about Z (proud by 17.6 um more for every 50 mm towards the back).
RIGHT_WALL = dict(x0=200.008, turn_deg=0.02)


def block():
    c = CHAMFER
    a = math.radians(c["angle_deg"])
    # The chamfer's face: through the top edge line y = top_width, z = 0, normal out of the
    # material (forwards and up), angle_deg from the top face's normal.
    n = (0.0, -math.sin(a), math.cos(a))
    w = RIGHT_WALL
    t = math.radians(w["turn_deg"])
    body = {"intersection": [box((0, 0, -40), (201, 100, 0)),
                             {"halfspace": {"point": mcs(0, c["top_width"], 0),
                                            "normal": [0.0, round(n[1], 12), round(n[2], 12)]}},
                             {"halfspace": {"point": mcs(w["x0"], 0, 0),
                                            "normal": [round(math.cos(t), 12),
                                                       round(-math.sin(t), 12), 0.0]}}]}
    p = POCKET
    cuts = [box((p["cx"] - p["sx"] / 2, p["cy"] - p["sy"] / 2, -p["depth"]),
                (p["cx"] + p["sx"] / 2, p["cy"] + p["sy"] / 2, 1))]
    s = SLOT
    cuts.append(box((s["cx"] - s["w"] / 2, s["y0"], -s["depth"]), (s["cx"] + s["w"] / 2, 101, 1)))
    cuts.append(box((SHELF["x0"], SHELF["y0"], -SHELF["depth"]), (201, 101, 1)))
    h = PCD
    for k in range(4):
        t = math.radians(90 * k + h["turn_deg"])
        cuts.append(cylinder(h["cx"] + h["d"] / 2 * math.cos(t), h["cy"] + h["d"] / 2 * math.sin(t),
                             -h["depth"], h["hole_d"] / 2, h["depth"] + 1))
    b = BOSS
    boss = cylinder(b["cx"], b["cy"], -1, b["d"] / 2, b["height"] + 1)
    c = CROWN
    crown = {"intersection": [
        cylinder(c["x0"], c["cy"], c["axis_z"], c["r"] + c["proud"], c["length"], axis=(1, 0, 0)),
        box((c["x0"], 20, -1), (c["x0"] + c["length"], 50, 5))]}
    return {"union": [{"difference": [body] + cuts}, boss, crown]}


def crown_nominal():
    """Vector points of the crown's drawing (R 50), 8 x 8 mm round its crest, every 0.5 mm."""
    c = CROWN
    rows = []
    for i in range(17):
        x = 176.0 + 0.5 * i
        for j in range(17):
            s = -4.0 + 0.5 * j  # arc length from the crest
            phi = s / c["r"]
            y = c["cy"] + c["r"] * math.sin(phi)
            z = c["axis_z"] + c["r"] * math.cos(phi)
            p = mcs(x, y, z)
            rows.append([p[0], p[1], p[2], 0.0, round(math.sin(phi), 12), round(math.cos(phi), 12)])
    return rows


def inspection():
    a60 = math.radians(60.0)
    ch = CHAMFER["top_width"]
    # The chamfer face's middle on the drawing: half way down its slope.
    slope = ch / math.cos(a60)  # its width along the slope
    mid = (0.0, ch - slope / 2 * math.cos(a60), -slope / 2 * math.sin(a60))
    hole_nominals = [{"top_centre_mm": mcs(35 + 15 * math.cos(math.radians(90 * k)),
                                           78 + 15 * math.sin(math.radians(90 * k)), 0),
                      "diameter_mm": 8.0, "depth_mm": 12.0} for k in range(4)]
    tol = {"upper_mm": 0.05, "lower_mm": 0.05}
    t = [
        {"feature": "rect_pocket",
         "nominal": {"centre_mm": mcs(40, 30, -7.5), "size_x_mm": 60, "size_y_mm": 40,
                     "within_mm": 6},
         "tolerance": tol,
         "truth": {"size_x_mm": POCKET["sx"], "size_y_mm": POCKET["sy"],
                   "centre_mm": mcs(POCKET["cx"], POCKET["cy"], -7.5)}},
        {"feature": "boss",
         "nominal": {"top_centre_mm": mcs(120, 30, 15), "diameter_mm": 30, "depth_mm": 15},
         "tolerance": tol,
         "truth": {"diameter_mm": BOSS["d"], "centre_mm": mcs(BOSS["cx"], BOSS["cy"], 15)}},
        {"feature": "pocket_width",
         "nominal": {"centre_mm": mcs(88, 78, -5), "direction": [1, 0, 0], "width_mm": 16,
                     "within_mm": 4},
         "tolerance": tol,
         "truth": {"width_mm": SLOT["w"], "centre_mm": mcs(SLOT["cx"], 78, -5)}},
        {"feature": "step",
         "nominal": {"a": {"point_mm": mcs(125, 75, 0), "normal": [0, 0, 1], "within_mm": 4},
                     "b": {"point_mm": mcs(150, 78, -10), "normal": [0, 0, 1], "within_mm": 4},
                     "height_mm": -10},
         "tolerance": tol,
         "truth": {"height_mm": -SHELF["depth"]}},
        {"feature": "pcd",
         "nominal": {"holes": hole_nominals, "centre_mm": mcs(35, 78, 0), "diameter_mm": 30},
         "tolerance": tol,
         "views_per_circle": 3,
         "truth": {"diameter_mm": PCD["d"], "centre_mm": mcs(PCD["cx"], PCD["cy"], 0),
                   "rotation_deg": PCD["turn_deg"]}},
        {"feature": "angle",
         "nominal": {"face": {"point_mm": mcs(100, mid[1], mid[2]),
                              "normal": [0, round(-math.sin(a60), 12), round(math.cos(a60), 12)],
                              "within_mm": 3},
                     "datum_direction": [0, 0, 1], "angle_deg": 60},
         "tolerance": {"upper_deg": 0.1, "lower_deg": 0.1},
         "truth": {"angle_deg": CHAMFER["angle_deg"]}},
        {"feature": "edge",
         "nominal": {"face": {"point_mm": mcs(199, 27.5, 0), "normal": [0, 0, 1],
                              "within_mm": 22},
                     "point_mm": mcs(200, 27.5, 0), "wall_normal": [1, 0, 0], "length_mm": 40},
         "tolerance": tol,
         "truth": {"offset_mm": round(RIGHT_WALL["x0"] - 200 + 27.5 * math.tan(
                       math.radians(RIGHT_WALL["turn_deg"])), 9),
                   "angle_deg": -RIGHT_WALL["turn_deg"]}},
        {"feature": "surface",
         "nominal": {"points": crown_nominal(), "spacing_mm": 0.5},
         "profile_tol_mm": 0.05,
         "truth": {"mean_mm": CROWN["proud"]}},
    ]
    return t


def main():
    scene = {
        "format": "mlprobe-scene/1",
        "comment": "A block with one of each feature the measure job knows, each a little off "
                   "its drawing; 'inspection' holds the requests a macro would send and the truth. "
                   "Written by make_features_block.py.",
        "flange_from_probe": {"translation_mm": [4.0, -2.5, 35.0],
                              "rotation_vector_rad": [0.018512012242326525, 0.018512012242326525, 0.0]},
        "workpiece": block(),
        "captures": [{"id": "top", "mcs_from_flange": {"translation_mm": [300.0, 150.0, -145.0],
                                                       "rotation_vector_rad": [math.pi, 0.0, 0.0]}}],
        "inspection": inspection(),
    }
    with open("features_block.json", "w") as f:
        json.dump(scene, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
