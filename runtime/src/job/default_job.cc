// The embedded default job of `vlt demo` and bare `vlt` (documented in docs/job-file.md,
// "The demo job"). Its numbers are checked by tests/test_results_demo.cc against an independent
// closed-form estimate of the tracker's coordinate uncertainty.
#include "vlt/job.h"

namespace vlt {

namespace {
constexpr const char kDefaultJob[] =
    R"vltjob(# vlt demo — the embedded default job (`vlt demo`, bare `vlt`; `vlt demo --show-job` prints it).
#
# A beam-steering-mirror laser tracker (model "mirror", Huo et al. 2010) measures a 4 m x 1.5 m
# panel lying on a fixture 0.8 m below the tracker's gimbal point, 3 m to 7 m away, offline: the
# points are nominal (a measurement plan) and vlt computes the readings that would measure them.
# The error parameters below are the uncertainty of a freshly compensated tracker; together with
# the reading noise they give expanded coordinate uncertainties of the order of a commercial
# tracker's specification, U(k=2) ~ 15 um + 6 um/m (docs/job-file.md, "The demo job").
# Every key: docs/job-file.md. Part frame = tracker frame (no [station]): x toward the panel,
# z up along the tracker's standing axis.

[job]
name = "vlt-demo"
description = "Mirror tracker, 4 m x 1.5 m panel at 3-7 m: 36 grid points, a bore, a tooling ball"

[tracker]
model = "mirror"

# Reading noise of every point (independent between points): ADM/IFM range noise a + b*range,
# encoder and servo noise of the two angles.
[tracker.noise]
range = "2.5 um + 0.3 um/m"
azimuth = "0.4 arcsec"
elevation = "0.4 arcsec"

# Residual error parameters after the tracker's compensation (estimates 0: compensated), their
# standard uncertainties and distributions. Omitted parameters take the model's defaults
# (`vlt model show mirror`); u = "0 um" would switch one off.
[tracker.parameters]
a0  = { u = "0.3 arcsec" }    # azimuth encoder index error
eac = { u = "0.3 arcsec" }    # azimuth encoder eccentricity (cos)
eas = { u = "0.3 arcsec" }    # azimuth encoder eccentricity (sin)
e0  = { u = "0.15 arcsec" }   # transit (mirror) encoder index; counts twice in the beam elevation
eec = { u = "0.15 arcsec" }   # transit encoder eccentricity (cos), mirror angle
ees = { u = "0.15 arcsec" }   # transit encoder eccentricity (sin), mirror angle
thv = { u = "2 um" }          # transit axis offset from the standing axis
rhv = { u = "0.4 arcsec" }    # transit axis non-perpendicularity
rmv = { u = "0.15 arcsec" }   # mirror tilt
tmv = { u = "2 um" }          # mirror plane offset
tbw = { u = "2 um" }          # incident beam offset (x)
tbv = { u = "2 um" }          # incident beam offset (y)
rbh = { u = "0.3 arcsec" }    # incident beam tilt about y
rbv = { u = "0.3 arcsec" }    # incident beam tilt about x
R0  = { u = "3 um" }          # dead path / bird-bath offset
mu  = { u = "0.5 ppm" }       # range scale
srr = { u = "1.5 um" }        # SMR vertex offset, radial
srh = { u = "1.5 um" }        # SMR vertex offset, lateral horizontal
srv = { u = "1.5 um" }        # SMR vertex offset, lateral vertical
sdh = { u = "0.3 arcsec" }    # SMR dihedral angle error

# The weather station at the tracker: the refractive index of the air scales every range.
[environment]
equation = "ciddor"
wavelength = "633 nm"
temperature = { estimate = "20.5 degC", u = "0.2 K" }
pressure = { estimate = "1013.25 hPa", u = "0.3 hPa" }
humidity = { estimate = "45 %", u = "5 %", distribution = "rectangular" }
co2 = { estimate = "450 ppm", u = "30 ppm" }

# The plan: nominal points in mm, part frame.
[plan]
unit = "mm"
point = [
# 9 x 4 grid over the panel, 500 mm pitch (columns A..I along x, rows 1..4 along y)
  {name = "PA1", x = 3000, y = -750, z = -800},
  {name = "PA2", x = 3000, y = -250, z = -800},
  {name = "PA3", x = 3000, y = 250, z = -800},
  {name = "PA4", x = 3000, y = 750, z = -800},
  {name = "PB1", x = 3500, y = -750, z = -800},
  {name = "PB2", x = 3500, y = -250, z = -800},
  {name = "PB3", x = 3500, y = 250, z = -800},
  {name = "PB4", x = 3500, y = 750, z = -800},
  {name = "PC1", x = 4000, y = -750, z = -800},
  {name = "PC2", x = 4000, y = -250, z = -800},
  {name = "PC3", x = 4000, y = 250, z = -800},
  {name = "PC4", x = 4000, y = 750, z = -800},
  {name = "PD1", x = 4500, y = -750, z = -800},
  {name = "PD2", x = 4500, y = -250, z = -800},
  {name = "PD3", x = 4500, y = 250, z = -800},
  {name = "PD4", x = 4500, y = 750, z = -800},
  {name = "PE1", x = 5000, y = -750, z = -800},
  {name = "PE2", x = 5000, y = -250, z = -800},
  {name = "PE3", x = 5000, y = 250, z = -800},
  {name = "PE4", x = 5000, y = 750, z = -800},
  {name = "PF1", x = 5500, y = -750, z = -800},
  {name = "PF2", x = 5500, y = -250, z = -800},
  {name = "PF3", x = 5500, y = 250, z = -800},
  {name = "PF4", x = 5500, y = 750, z = -800},
  {name = "PG1", x = 6000, y = -750, z = -800},
  {name = "PG2", x = 6000, y = -250, z = -800},
  {name = "PG3", x = 6000, y = 250, z = -800},
  {name = "PG4", x = 6000, y = 750, z = -800},
  {name = "PH1", x = 6500, y = -750, z = -800},
  {name = "PH2", x = 6500, y = -250, z = -800},
  {name = "PH3", x = 6500, y = 250, z = -800},
  {name = "PH4", x = 6500, y = 750, z = -800},
  {name = "PI1", x = 7000, y = -750, z = -800},
  {name = "PI2", x = 7000, y = -250, z = -800},
  {name = "PI3", x = 7000, y = 250, z = -800},
  {name = "PI4", x = 7000, y = 750, z = -800},
# a 100 mm bore in the panel, 8 points on its edge (SMR in a hole adapter)
  {name = "B1", x = 5300, y = 250, z = -800},
  {name = "B2", x = 5285.355339059, y = 285.355339059, z = -800},
  {name = "B3", x = 5250, y = 300, z = -800},
  {name = "B4", x = 5214.644660941, y = 285.355339059, z = -800},
  {name = "B5", x = 5200, y = 250, z = -800},
  {name = "B6", x = 5214.644660941, y = 214.644660941, z = -800},
  {name = "B7", x = 5250, y = 200, z = -800},
  {name = "B8", x = 5285.355339059, y = 214.644660941, z = -800},
# a tooling ball: SMR centres on a 50 mm sphere about its centre (pole + 5 at 30 deg elevation)
  {name = "S1", x = 6500, y = -500, z = -600},
  {name = "S2", x = 6543.301270189, y = -500, z = -625},
  {name = "S3", x = 6513.380828366, y = -458.818044823, z = -625},
  {name = "S4", x = 6464.968536539, y = -474.548151977, z = -625},
  {name = "S5", x = 6464.968536539, y = -525.451848023, z = -625},
  {name = "S6", x = 6513.380828366, y = -541.181955177, z = -625},
]

# What is derived from the points (GUM with the correlation the shared inputs cause between the
# points; Monte Carlo refits every trial).
[[task]]
kind = "distance"
name = "length_A1_I1"
points = ["PA1", "PI1"]

[[task]]
kind = "plane"
name = "panel_plane"
points = ["PA1", "PA2", "PA3", "PA4", "PB1", "PB2", "PB3", "PB4", "PC1", "PC2", "PC3", "PC4", "PD1", "PD2", "PD3", "PD4", "PE1", "PE2", "PE3", "PE4", "PF1", "PF2", "PF3", "PF4", "PG1", "PG2", "PG3", "PG4", "PH1", "PH2", "PH3", "PH4", "PI1", "PI2", "PI3", "PI4"]

[[task]]
kind = "circle"
name = "bore_B"
points = ["B1", "B2", "B3", "B4", "B5", "B6", "B7", "B8"]

[[task]]
kind = "sphere"
name = "tooling_ball"
points = ["S1", "S2", "S3", "S4", "S5", "S6"]

# Monte Carlo (JCGM 101/102): the same model sampled, every point and task, and the GUM results
# validated against it (JCGM 101 8). n_dig = 1: the tolerance is half a unit in the first digit
# of u (JCGM 101 7.9.2). With n_dig = 2 the tolerance (0.05 um for u = 7 um) is below the
# numerical noise of 2e5 trials; use adaptive = true with n_dig = 2 for that stricter check.
[monte_carlo]
trials = 200000
seed = 20260101
n_dig = 1
coverage_probability = 0.95

# The GUM expanded uncertainty over the panel's plane (map.csv, map.html, and in report.html).
[map]
plane = "z = -0.8 m"
extent = "2.5 m, 7.5 m, -2 m, 2 m"
step = "0.1 m"
)vltjob";
}  // namespace

std::string_view DefaultJobToml() { return {kDefaultJob, sizeof(kDefaultJob) - 1}; }

}  // namespace vlt
