#!/usr/bin/env python3
"""Writes board_scene.json: a 9 x 6 chessboard of 2.5 mm squares on the table (board frame =
machine frame, face z = 0) and 16 probe poses looking at it from 115-135 mm, tilted up to
~35 degrees about x and y and shifted so that over the views the board reaches the image's
corners (what camera/projector calibration needs: docs/CALIBRATION.md). Pure Python (no numpy)
so that it runs anywhere; the JSON it wrote is committed beside it."""
import json
import math
import os
import sys

# The rotation helpers live beside the other scene generator.
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scenes"))
from scene_math import rotation_vector  # noqa: E402

COLS, ROWS, SQUARE_MM, VIEWS = 9, 6, 2.5, 16


def matmul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def rot(axis, angle):
    c, s = math.cos(angle), math.sin(angle)
    if axis == "x":
        return [[1, 0, 0], [0, c, -s], [0, s, c]]
    if axis == "y":
        return [[c, 0, s], [0, 1, 0], [-s, 0, c]]
    return [[c, -s, 0], [s, c, 0], [0, 0, 1]]


def main():
    half = [0.5 * (COLS + 1) * SQUARE_MM, 0.5 * (ROWS + 1) * SQUARE_MM, 0.0]
    captures = []
    for v in range(VIEWS):
        a, c = 0.6 * math.sin(1.7 * v), 0.55 * math.cos(2.3 * v)
        # camera_from_board: the camera looks down (x turned by pi), then tilted.
        r = matmul(matmul(matmul(rot("x", math.pi), rot("y", a)), rot("x", c)), rot("z", 0.2 * math.sin(v)))
        centre = [9.0 * math.sin(2.9 * v), 7.0 * math.cos(1.1 * v), 125.0 + 10.0 * math.sin(0.9 * v)]
        t = [centre[i] - sum(r[i][k] * half[k] for k in range(3)) for i in range(3)]
        # mcs_from_probe = inverse(camera_from_board); the flange is the probe frame (M = I).
        rt = [[r[j][i] for j in range(3)] for i in range(3)]
        pos = [-sum(rt[i][k] * t[k] for k in range(3)) for i in range(3)]
        captures.append({"id": "view%02d" % (v + 1),
                         "mcs_from_flange": {"translation_mm": [round(x, 9) for x in pos],
                                             "rotation_vector_rad": rotation_vector(rt)}})
    scene = {
        "format": "mlprobe-scene/1",
        "comment": "Calibration target: 9 x 6 inner corners, 2.5 mm squares, board frame = MCS "
                   "(face z = 0); 16 views for camera/projector calibration. Written by "
                   "make_board_scene.py.",
        "flange_from_probe": {"translation_mm": [0, 0, 0], "rotation_vector_rad": [0, 0, 0]},
        "workpiece": {"chessboard": {"pose": {"translation_mm": [0, 0, 0], "rotation_vector_rad": [0, 0, 0]},
                                     "inner_cols": COLS, "inner_rows": ROWS, "square_mm": SQUARE_MM,
                                     "dark_reflectance": 0.08},
                      "reflectance": 0.8},
        "captures": captures,
    }
    with open("board_scene.json", "w") as f:
        json.dump(scene, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
