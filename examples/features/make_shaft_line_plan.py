#!/usr/bin/python3
"""Writes shaft_line_plan.csv: the nominal points of examples/features/shaft_line.toml.

Part frame: the shaft line along +x, z up, millimetres. Two bearing bores of 600 mm diameter
(aft at x = 0..600, forward at x = 4000..4600), probed in three rings of eight points each, and
the propeller shaft's taper: a cone of 1:15 on the diameter (half-angle atan(1/30) = 1.909 deg),
500 mm diameter at x = 6000, narrowing towards +x, probed in three rings of eight.
Run from this folder: /usr/bin/python3 make_shaft_line_plan.py
"""
import math

rows = []
def ring(prefix, x, radius, ring_index, count=8, phase=0.0):
    for k in range(count):
        phi = phase + 2.0 * math.pi * k / count
        rows.append((f"{prefix}{ring_index}{k + 1}", x, radius * math.cos(phi), radius * math.sin(phi)))

for i, x in enumerate((50.0, 300.0, 550.0), start=1):
    ring("A", x, 300.0, i, phase=0.2 * i)          # aft bearing bore
for i, x in enumerate((4050.0, 4300.0, 4550.0), start=1):
    ring("B", x, 300.0, i, phase=0.2 * i)          # forward bearing bore
for i, x in enumerate((6000.0, 6200.0, 6400.0), start=1):
    r = 250.0 - (x - 6000.0) / 30.0                # 1:15 on the diameter
    ring("T", x, r, i, phase=0.2 * i)              # shaft taper

with open("shaft_line_plan.csv", "w") as out:
    out.write("# Nominal points of a stern-tube shaft line (examples/features/shaft_line.toml), part frame,\n")
    out.write("# millimetres (ten decimals: the points lie on their surfaces to 1e-13 m); written by\n")
    out.write("# make_shaft_line_plan.py. Columns: name, x, y, z.\n")
    out.write("name,x,y,z\n")
    for name, x, y, z in rows:
        out.write(f"{name},{x:.10f},{y:.10f},{z:.10f}\n")
