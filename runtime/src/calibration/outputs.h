// calibration/outputs.h — the files `vlt test` and `vlt calibrate` write (docs/calibration.md,
// "Outputs"); each function returns (file name, content) pairs for an all-or-none write.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "vlt/calibration.h"

namespace vlt::calibration_outputs {

using Files = std::vector<std::pair<std::string, std::string>>;

// tests.csv, sensitivity.csv, results.json, report.html; with simulated data also
// simulated_readings.csv and simulated_calibration.toml (a `vlt calibrate` input).
Files TestFiles(const TestJob& job, const std::vector<TestResult>& results,
                const CalibrationData* simulated);

// calibration.toml (the calibration file), parameters.csv, correlation.csv,
// identifiability.csv, targets.csv, residuals.csv, results.json, report.html.
Files CalibrationFiles(const CalibrationJob& job, const CalibrationResult& result,
                       const CalibrationProvenance& provenance);

// The parameter's display unit and the factor from SI: length -> um (1e6), angle -> arcsec,
// ratio -> ppm (1e6); anything else keeps its SI unit.
std::pair<std::string, double> DisplayUnit(const std::string& quantity, const std::string& si_unit);

// One-line terminal summaries.
std::string TestSummary(const TestJob& job, const std::vector<TestResult>& results);
std::string CalibrationSummary(const CalibrationJob& job, const CalibrationResult& result);

}  // namespace vlt::calibration_outputs
