// network/instruments.cc — MakeInstruments (instruments.h) and NetworkSharedInputNames.
#include "network/instruments.h"

#include "vlt/error.h"

namespace vlt {

namespace network_internal {

Instruments MakeInstruments(const Network& network) {
  if (network.instruments.empty())
    throw InputError(network.where + ": tracker: the network has no instrument");
  Instruments in;
  int total = 0;
  for (const NetworkInstrument& instrument : network.instruments) {
    MeasurementSetup setup = instrument.setup;
    setup.pose.reset();
    setup.thermal.reset();
    in.models.emplace_back(setup);
    in.offset.push_back(total);
    total += in.models.back().num_shared();
  }
  in.s0.resize(total);
  in.sigma = Eigen::MatrixXd::Zero(total, total);
  in.correlation = Eigen::MatrixXd::Zero(total, total);
  const bool several = network.instruments.size() > 1;
  for (std::size_t k = 0; k < in.models.size(); ++k) {
    const MeasurementModel& m = in.models[k];
    const int o = in.offset[k], n = m.num_shared();
    in.s0.segment(o, n) = m.shared_estimates();
    Eigen::VectorXd u(n);
    for (int i = 0; i < n; ++i) {
      u(i) = m.shared_inputs()[i].u;
      in.names.push_back((several ? network.instruments[k].name + "." : std::string()) +
                         m.shared_inputs()[i].name);
    }
    in.correlation.block(o, o, n, n) = m.shared_correlation();
    in.sigma.block(o, o, n, n) = u.asDiagonal() * m.shared_correlation() * u.asDiagonal();
  }
  for (const NetworkStation& st : network.stations) {
    if (st.instrument < 0 || st.instrument >= static_cast<int>(network.instruments.size())) {
      throw InputError(st.where + ".instrument: no such instrument");
    }
  }
  return in;
}

}  // namespace network_internal

std::vector<std::string> NetworkSharedInputNames(const Network& network) {
  return network_internal::MakeInstruments(network).names;
}

}  // namespace vlt
