#!/usr/bin/env bash
# CI stage 2: the test suite built with Clang, AddressSanitizer + UndefinedBehaviorSanitizer
# (+ float-cast-overflow), in build-sanitize/ — the build that stage 3 (scripts/test-fuzz.sh) fuzzes.
# Every test but those labelled `browser` (a headless browser rendering a page; the runs that wrote
# the page are tests of their own and do run here) and the statistical studies below, which repeat
# one computation over hundreds of seeds (a calibration, a network adjustment) or over 10^5 points
# (and the count of the work items of a 10^6-trial Monte Carlo run on 16 threads, 44 s here; the
# alignment's Monte Carlo reference, 40000 re-alignments of 4 tasks, 19 s here; the cylinder and
# cone fits' 8000 refits with Jacobian, 40 s here; the air by time over 300 seeds, 26 s; the
# weighted fits over 4000 draws and against a tracker job's Monte Carlo, 24 s and 11 s; 2000 trackers
# drawn from a prior, twice 14 s; 800 random bores and shafts, 12 s; the shaft line's 2000 Monte
# Carlo trials of cylinder, cone and minimum-zone fits, 66 s, the least the JCGM 101 7.2.2 rule
# allows for p = 0.95, whose fits run here in AxialFits.* and MinimumZone.*; measured 2026-11-28):
# their code paths run here once in the tests that check them against closed forms and finite
# differences, and stage 1 runs the studies themselves (docs/testing.md). Under the sanitizers they
# took 348 of the stage's 728 test seconds (measured 2026-11-26; the two calibration coverage
# studies, excluded before, another 577).
set -euo pipefail
source "$(dirname "$0")/lib.sh"
studies=(
  CalibrationTests.CoverageOfIdentifiedParametersOverManySeeds
  CalibrationTests.CoverageWithExcludedParametersCarriesTheirPriors
  Network.CoverageOfTheAdjustedTargetsWithAKnownTruth
  Network.SelfCalibrationRecoversTheTrueParameters
  Network.SeveralInstrumentsCoverTheTruth
  Network.ScaleBarNetworkCoversTheRangeScale
  Network.StationAirCoversTheTruth
  Network.RobustRuleRemovesGrossErrors
  Network.DriftModelCoversTheTargetsReadBetweenChecks
  cli_run_scan_large
  McmThreads.EveryPhaseOffersEightItemsToEachOfSixteenThreads
  Alignment.GumCovarianceAgreesWithMonteCarlo
  Network.PlannedDriftIsCoveredBySimulatedMeasurements
  AxialFits.GumCovarianceAgreesWithMonteCarloAndCoversTheTruth
  ScanFiles.EveryParallelPhaseOfA1e5PointScanOffersEightItemsToEachOfSixteenThreads
  ScanFiles.SameBytesForOneTwoThreeAndSixteenThreads
  TailIndex.ARatioWhoseDivisorMayBeZeroHasNoFiniteVariance
  Network.AirThatChangesCoversTheTruth
  WeightedFits.SpreadOverDrawsIsTheGumCovarianceAndBelowTheOrdinaryFit
  WeightedFits.OnATrackerJobTheGumAgreesWithMonteCarloAndWeightingHelps
  DerivePrior.DrawnTrackersMeetTheStatementsAtTheStatedProbability
  DerivePrior.DrawnTrackersConformAtOtherProbabilities
  AxialFits.SurfacesAsLongAsTheyAreWideAreFoundAndNotRefused
  cli_features_shaft_line
)
exclude="^($(IFS='|'; echo "${studies[*]}" | sed 's/[.]/[.]/g'))$"
vlt_build_sanitize
cd "$VLT_ROOT/build-sanitize"
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  LSAN_OPTIONS=suppressions=$VLT_ROOT/scripts/lsan.supp:print_suppressions=0 \
  ctest --output-on-failure -j2 -LE browser -E "$exclude" "$@"
