// instrument/readers.h — the instrument of a job file: [tracker] (with its calibration file),
// [environment], [station], [part] and [correlations], read alike by the readers of jobs, networks
// and calibrations (instrument/readers.cc).
#pragma once

#include <string>
#include <vector>

#include "base/section.h"
#include "vlt/job.h"

namespace vlt::instrument_internal {

using namespace base_internal;  // Section and the readers of values with units

// calibration: a calibration file that replaces [tracker] calibration (`vlt run --calibration`; its
// path as given, relative to the working directory); nullptr: the job's own.
void ReadTracker(Section& top, Job& job, const std::string* calibration = nullptr);  //  [tracker]
void ReadEnvironment(Section& top, Job& job);                                        //  [environment]
// The keys of an existing environment table `s` ([environment], a network's [station.environment]);
// `more_keys` are the caller's own keys of that table, already read (for the hint of an unknown key).
// The table is finished. Estimates outside the equation's range of validity are computed, with a
// warning appended to `warnings` (an error under --strict).
Environment ReadAir(Section& s, std::vector<std::string>& warnings, const std::string& more_keys = "");
void ReadStation(Section& top, Job& job);       //  [station]
void ReadPart(Section& top, Job& job);          //  [part]
void ReadCorrelations(Section& top, Job& job);  //  [correlations] (after the above)

// One [<...>.correlations.<name>] table: `<inputs_key>` = [names] and matrix = [[...]]; the
// meaning is checked by SharedCorrelation (vlt/measurement_model.h) with the other groups.
CorrelationGroup ReadCorrelationGroup(Section& parent, const std::string& name,
                                      const std::string& inputs_key);
// "5 um + 0.5 um/m" -> (a [m], b [m/m]); either term may be absent.
void ParseLengthPlusRatio(const std::string& text, const std::string& where, double& a, double& b);

}  // namespace vlt::instrument_internal
