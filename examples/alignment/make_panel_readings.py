#!/usr/bin/env python3
"""Writes the example's nominal CSV and the readings a tracker would export for it.

The part: a 2.4 m x 1.2 m panel, gently curved (z = 0.04 sin(x/1.2) mm-scale relief in m),
with four tooling holes T1-T4 (normal: the hole axis, +z) and twenty surface points S01-S20 (normal:
the outward surface normal). The made part deviates from nominal along the normals: a few tenths
of a millimetre, S17 by +0.21 mm (outside the +-0.15 mm profile band) and T3's hole 0.08 mm off its
axis. The tracker stands 3.5 m from the panel's centre, turned 160 degrees to the part's frame; the
readings are its ideal spherical coordinates of the made points (every error parameter zero, no
refraction: the job's [environment] is absent) with a reading noise of 3 um + 0.4 arcsec, rounded
as tracker software exports them. Run again to regenerate (fixed seed); pure Python, no packages.
"""
import math
import random

random.seed(20261126)

def nominal_points():
    pts = []
    for name, x, y in (("T1", 0.1, 0.1), ("T2", 2.3, 0.1), ("T3", 2.3, 1.1), ("T4", 0.1, 1.1)):
        pts.append((name, x, y, surface(x), (0.0, 0.0, 1.0)))
    k = 1
    for j in range(4):
        for i in range(5):
            x, y = 0.25 + 0.475 * i, 0.2 + 0.27 * j
            pts.append((f"S{k:02d}", x, y, surface(x), normal(x)))
            k += 1
    return pts

def surface(x):
    return 0.04 * math.sin(x / 1.2)

def normal(x):
    slope = 0.04 / 1.2 * math.cos(x / 1.2)
    n = (-slope, 0.0, 1.0)
    length = math.sqrt(sum(c * c for c in n))
    return tuple(c / length for c in n)

def made(name, p, n):
    if name == "S17":
        d = 0.21e-3
    elif name.startswith("S"):
        d = random.gauss(0.0, 0.05e-3)
    else:
        d = 0.0
    q = [p[c] + d * n[c] for c in range(3)]
    if name == "T3":
        q[0] += 0.08e-3 / 2 ** 0.5
        q[1] -= 0.08e-3 / 2 ** 0.5
    return q

def to_tracker(q):
    # part = R x + t with R = Rz(160 deg): the tracker at (1.2, -2.9, 0.35) in the part frame
    a = math.radians(160.0)
    t = (1.2, -2.9, 0.35)
    d = [q[c] - t[c] for c in range(3)]
    return (math.cos(a) * d[0] + math.sin(a) * d[1], -math.sin(a) * d[0] + math.cos(a) * d[1], d[2])

def main():
    arcsec = math.pi / 180 / 3600
    with open("panel_nominal.csv", "w") as nominal, open("panel_readings.csv", "w") as readings:
        nominal.write("# The panel's CAD points (mm) and unit normals: T = tooling hole (axis), S = surface\n")
        nominal.write("name,x,y,z,i,j,k\n")
        readings.write("# Readings exported from the tracker: distance in mm, azimuth and elevation in deg\n")
        readings.write("name,distance,azimuth,elevation\n")
        for name, x, y, z, n in nominal_points():
            nominal.write(f"{name},{x * 1e3:.4f},{y * 1e3:.4f},{z * 1e3:.4f},{n[0]:.6f},{n[1]:.6f},{n[2]:.6f}\n")
            px, py, pz = to_tracker(made(name, (x, y, z), n))
            r = math.sqrt(px * px + py * py + pz * pz) + random.gauss(0.0, 3e-6)
            az = math.atan2(py, px) + random.gauss(0.0, 0.4 * arcsec)
            el = math.atan2(pz, math.hypot(px, py)) + random.gauss(0.0, 0.4 * arcsec)
            readings.write(f"{name},{r * 1e3:.4f},{math.degrees(az):.7f},{math.degrees(el):.7f}\n")

if __name__ == "__main__":
    main()
