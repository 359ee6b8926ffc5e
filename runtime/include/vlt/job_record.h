// vlt/job_record.h — who measured what, for whom and where: the administrative items a report one
// signs carries (ISO/IEC 17025:2017 7.8.2: the customer, the item and the equipment, the
// location, the conditions), read from [job] of a run, custom or network job and printed in the
// header of its summary and report and in results.json `job.record` (docs/job-file.md "[job]").
#pragma once

#include <string>

namespace vlt {

// The tracker (or other instrument) as its owner identifies it.
struct InstrumentIdentity {
  std::string make;    // [job.instrument] make, e.g. "Leica"
  std::string model;   // [job.instrument] model, e.g. "AT960-MR"
  std::string serial;  // [job.instrument] serial
};

// Free one-line texts; empty when not given. None of them changes a number.
struct JobRecord {
  std::string customer;           // [job] customer
  InstrumentIdentity instrument;  // [job.instrument]
  std::string operator_name;      // [job] operator
  std::string place;              // [job] place
  std::string conditions;         // [job] conditions, e.g. "hall 3, 20.5 +- 0.5 degC, no draught"
  bool empty() const {
    return customer.empty() && instrument.make.empty() && instrument.model.empty() &&
           instrument.serial.empty() && operator_name.empty() && place.empty() && conditions.empty();
  }
};

// "Leica AT960-MR, serial 123456" (the parts given, in that order); "" when none is.
std::string DescribeInstrument(const InstrumentIdentity& instrument);

}  // namespace vlt
