// model/refractive_index.cc — phase refractive index of moist air (Edlén/Bönsch-Potulski 1998,
// Ciddor 1996, NIST's modified Edlén/Birch-Downs 1993-94) with exact partial derivatives by
// forward-mode automatic differentiation.
//
// Every equation is written once, templated on the scalar type: double for the value-only path
// used by Monte Carlo trials, Eigen::AutoDiffScalar with 4 derivative directions
// (temperature, pressure, humidity, CO2) for the GUM path. Equation numbers refer to the papers
// and to J. A. Stone, J. H. Zimmerman, "Index of Refraction of Air", NIST Engineering Metrology
// Toolbox, Appendix A (A-I saturation vapour pressure, A-II humidity, A-III Ciddor, A-IV modified
// Edlén).
#include "vlt/refractive_index.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

#include <Eigen/Core>
#include <unsupported/Eigen/AutoDiff>

#include "vlt/error.h"

namespace vlt {
namespace {

using Gradient = Eigen::Matrix<double, 4, 1>;
using Dual = Eigen::AutoDiffScalar<Gradient>;

constexpr double kZeroCelsius = 273.15;  // K

double Value(double x) { return x; }
double Value(const Dual& x) { return x.value(); }

// --- Saturation vapour pressure (NIST Appendix A-I) --------------------------------------------

// Over liquid water: IAPWS-IF97 region-4 saturation equation (eq. 30, the "backward" form giving
// p_s from T), coefficients n1..n10 of IAPWS-IF97 table 34.
template <typename T>
T SvpOverWater(const T& t_degc) {
  constexpr double K1 = 1.16705214528e3, K2 = -7.24213167032e5, K3 = -1.70738469401e1, K4 = 1.20208247025e4,
                   K5 = -3.23255503223e6, K6 = 1.49151086135e1, K7 = -4.82326573616e3, K8 = 4.05113405421e5,
                   K9 = -2.38555575678e-1, K10 = 6.50175348448e2;
  using std::sqrt;
  const T temperature = t_degc + kZeroCelsius;  // K
  const T omega = temperature + K9 / (temperature - K10);
  const T a = omega * omega + K1 * omega + K2;
  const T b = K3 * omega * omega + K4 * omega + K5;
  const T c = K6 * omega * omega + K7 * omega + K8;
  const T x = -b + sqrt(b * b - 4.0 * a * c);
  const T ratio = 2.0 * c / x;
  const T r2 = ratio * ratio;
  return 1e6 * r2 * r2;  // MPa -> Pa
}

// Over ice: IAPWS 1993 (Wagner, Saul, Pruss) sublimation pressure, as NIST A-I prescribes below
// 0 degC: ln(p/611.657 Pa) = A1 (1 - theta^-1.5) + A2 (1 - theta^-1.25), theta = T / 273.16 K.
template <typename T>
T SvpOverIce(const T& t_degc) {
  using std::exp;
  using std::pow;
  constexpr double A1 = -13.928169, A2 = 34.7078238;
  const T theta = (t_degc + kZeroCelsius) / 273.16;
  return 611.657 * exp(A1 * (1.0 - pow(theta, -1.5)) + A2 * (1.0 - pow(theta, -1.25)));
}

template <typename T>
T Svp(const T& t_degc) {
  return Value(t_degc) >= 0.0 ? SvpOverWater(t_degc) : SvpOverIce(t_degc);
}

double Sq(double x) { return x * x; }

// A dispersion term g of the equations below, a function of sigma^2 (sigma = 1 / vacuum wavelength,
// in 1/um): itself for the phase index; for the group index n_g = n - lambda dn/dlambda =
// n + sigma dn/dsigma, g + sigma dg/dsigma = g + 2 sigma^2 dg/d(sigma^2) (Ciddor & Hill, Appl.
// Opt. 38 (1999) 1663, eq. (2): every equation here is linear in its dispersion terms, whose
// factors depend on temperature, pressure, humidity and CO2 only). dg: dg/d(sigma^2), exact.
double Group(RangingIndex index, double sigma2, double g, double dg) {
  return index == RangingIndex::kGroup ? g + 2.0 * sigma2 * dg : g;
}

// --- Ciddor 1996 (NIST Appendix A-III) ----------------------------------------------------------
template <typename T>
T Ciddor(double sigma2, RangingIndex index, const T& t, const T& p, const T& h, const T& co2) {
  // Dispersion of standard dry air (15 degC, 101325 Pa, 450 umol/mol CO2), Ciddor eq. (1), and of
  // pure water vapour (20 degC, 1333 Pa), eq. (3) with the 1.022 correction factor.
  constexpr double k0 = 238.0185, k1 = 5792105.0, k2 = 57.362, k3 = 167917.0;
  constexpr double w0 = 295.235, w1 = 2.6422, w2 = -0.032380, w3 = 0.004028;
  // BIPM-1981/91 compressibility, Ciddor eq. (12), table 1.
  constexpr double a0 = 1.58123e-6, a1 = -2.9331e-8, a2 = 1.1043e-10;
  constexpr double b0 = 5.707e-6, b1 = -2.051e-8, c0 = 1.9898e-4, c1 = -2.376e-6;
  constexpr double d = 1.83e-11, e = -0.765e-8;
  // Reference conditions and constants (NIST A-III).
  constexpr double p_r1 = 101325.0, t_r1 = 288.15, z_a = 0.9995922115, rho_vs = 0.00985938;
  constexpr double R = 8.314472, M_v = 0.018015;
  // Enhancement factor of water vapour in air, Ciddor appendix / NIST A-II.
  constexpr double alpha = 1.00062, beta = 3.14e-8, gamma = 5.6e-7;

  const T temperature = t + kZeroCelsius;
  const T f = alpha + beta * p + gamma * t * t;
  const T x_v = (h / 100.0) * f * Svp(t) / p;  // water vapour mole fraction
  const T x_c = co2 * 1e6;                     // CO2 in umol/mol

  // Phase: the dispersion terms g(sigma^2); group: g + 2 sigma^2 g' (Group below).
  const double n_as1 = Group(index, sigma2, 1e-8 * (k1 / (k0 - sigma2) + k3 / (k2 - sigma2)),
                             1e-8 * (k1 / Sq(k0 - sigma2) + k3 / Sq(k2 - sigma2)));
  const T n_axs1 = n_as1 * (1.0 + 0.534e-6 * (x_c - 450.0));  // eq. (2)
  const double n_ws1 = Group(index, sigma2,
                             1.022e-8 * (w0 + w1 * sigma2 + w2 * sigma2 * sigma2 + w3 * sigma2 * sigma2 * sigma2),
                             1.022e-8 * (w1 + 2.0 * w2 * sigma2 + 3.0 * w3 * sigma2 * sigma2));
  const T m_a = 0.0289635 + 1.2011e-8 * (x_c - 400.0);  // eq. (4), kg/mol

  const T pt = p / temperature;
  const T z = 1.0 - pt * (a0 + a1 * t + a2 * t * t + (b0 + b1 * t) * x_v + (c0 + c1 * t) * x_v * x_v) +
              pt * pt * (d + e * x_v * x_v);              // eq. (12)
  const T rho_axs = p_r1 * m_a / (z_a * R * t_r1);        // eq. (4)
  const T rho_v = x_v * p * M_v / (z * R * temperature);  // eq. (4)
  const T rho_a = (1.0 - x_v) * p * m_a / (z * R * temperature);
  return 1.0 + (rho_a / rho_axs) * n_axs1 + (rho_v / rho_vs) * n_ws1;  // eq. (5)
}

// --- Edlén as updated by Bönsch & Potulski 1998 ------------------------------------------------
template <typename T>
T EdlenBoensch(double sigma2, RangingIndex index, const T& t, const T& p, const T& h, const T& co2) {
  // Standard air (15 degC, 101325 Pa, 400 umol/mol CO2, dry), B&P eq. (6).
  const double n_n1 = Group(index, sigma2, 1e-8 * (8091.37 + 2333983.0 / (130.0 - sigma2) + 15518.0 / (38.9 - sigma2)),
                            1e-8 * (2333983.0 / Sq(130.0 - sigma2) + 15518.0 / Sq(38.9 - sigma2)));
  const double water = Group(index, sigma2, 3.8020 - 0.0384 * sigma2, -0.0384);
  const T n_x1 = n_n1 * (1.0 + 0.5327 * (co2 - 0.0004));  // eq. (7)
  const T n_tp1 =
      n_x1 * p * (1.0 + 1e-8 * (0.5953 - 0.009876 * t) * p) / (93214.60 * (1.0 + 0.0036610 * t));  // eq. (8)
  const T f = (h / 100.0) * Svp(t);                             // water vapour partial pressure, Pa
  return 1.0 + n_tp1 - f * water * 1e-10;  // eq. (9)
}

// --- Modified Edlén (NIST Appendix A-IV): Birch & Downs 1993/1994 with NIST's water term -------
// Standard air of Birch & Downs: 15 degC, 101325 Pa, dry, 450 umol/mol CO2. The CO2 content is
// built into the dispersion constants, so CO2 is not an argument: dn/dCO2 = 0. NIST multiplies
// B&D's water-vapour term by 292.75 K / T (so that it stays right away from 20 degC,
// "shop-floor" use).
template <typename T>
T EdlenBirchDowns(double sigma2, RangingIndex index, const T& t, const T& p, const T& h) {
  constexpr double A = 8342.54, B = 2406147.0, C = 15998.0;             // dispersion
  constexpr double D = 96095.43, E = 0.601, F = 0.00972, G = 0.003661;  // density (t, p)
  const double n_s1 = Group(index, sigma2, 1e-8 * (A + B / (130.0 - sigma2) + C / (38.9 - sigma2)),
                            1e-8 * (B / Sq(130.0 - sigma2) + C / Sq(38.9 - sigma2)));  // (n_s - 1)
  const double water = Group(index, sigma2, 3.7345 - 0.0401 * sigma2, -0.0401);
  const T x = (1.0 + 1e-8 * (E - F * t) * p) / (1.0 + G * t);
  const T n_tp1 = p * n_s1 * x / D;    // (n_tp - 1)
  const T p_v = (h / 100.0) * Svp(t);  // water vapour partial pressure, Pa (NIST A-II)
  return 1.0 + n_tp1 - 1e-10 * (292.75 / (t + kZeroCelsius)) * water * p_v;
}

template <typename T>
T Evaluate(AirEquation equation, double sigma2, RangingIndex index, const T& t, const T& p, const T& h,
           const T& co2) {
  switch (equation) {
    case AirEquation::kCiddor: return Ciddor(sigma2, index, t, p, h, co2);
    case AirEquation::kEdlenBirchDowns:
      return EdlenBirchDowns(sigma2, index, t, p, h);  // CO2 is not an input of this equation
    case AirEquation::kEdlenBoensch: break;
  }
  return EdlenBoensch(sigma2, index, t, p, h, co2);
}

std::string Num(double x) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%g", x);
  return buffer;
}

// Physically impossible inputs; returns sigma^2 in um^-2.
double CheckPhysical(const AirConditions& air, std::string_view where) {
  const std::string prefix = std::string(where) + ": ";
  const auto finite = [&](double v, const char* what) {
    if (!std::isfinite(v)) throw InputError(prefix + what + " is not a finite number");
  };
  finite(air.vacuum_wavelength, "vacuum wavelength");
  finite(air.temperature, "temperature");
  finite(air.pressure, "pressure");
  finite(air.humidity, "humidity");
  finite(air.co2, "CO2 fraction");
  if (air.vacuum_wavelength <= 0.0) {
    throw InputError(prefix + "vacuum wavelength " + Num(air.vacuum_wavelength) + " m must be positive");
  }
  if (air.temperature <= -kZeroCelsius) {
    throw InputError(prefix + "temperature " + Num(air.temperature) + " degC is at or below absolute zero");
  }
  if (air.pressure <= 0.0) {
    throw InputError(prefix + "pressure " + Num(air.pressure) + " Pa must be positive");
  }
  if (air.humidity < 0.0 || air.humidity > 100.0) {
    throw InputError(prefix + "relative humidity " + Num(air.humidity) + " % is outside 0..100 %");
  }
  if (air.co2 < 0.0 || air.co2 >= 1.0) {
    throw InputError(prefix + "CO2 mole fraction " + Num(air.co2) +
                     " is outside [0, 1) (450 umol/mol is 450e-6)");
  }
  const double sigma = 1e-6 / air.vacuum_wavelength;  // um^-1
  return sigma * sigma;
}

void CheckFinite(double v, std::string_view where) {
  if (!std::isfinite(v)) {
    throw NumericalError(std::string(where) +
                         ": refractive index is not finite (wavelength on a dispersion pole?)");
  }
}

}  // namespace

std::string_view AirEquationName(AirEquation equation) {
  switch (equation) {
    case AirEquation::kCiddor: return "ciddor";
    case AirEquation::kEdlenBirchDowns: return "modified_edlen";
    case AirEquation::kEdlenBoensch: break;
  }
  return "edlen";
}

AirEquation ParseAirEquation(std::string_view text, std::string_view where) {
  // Every accepted spelling; the first of each equation is its AirEquationName.
  static constexpr struct {
    std::string_view name;
    AirEquation equation;
  } kSpellings[] = {
      {"ciddor", AirEquation::kCiddor},
      {"edlen", AirEquation::kEdlenBoensch},
      {"edlen_boensch", AirEquation::kEdlenBoensch},
      {"boensch_potulski", AirEquation::kEdlenBoensch},
      {"modified_edlen", AirEquation::kEdlenBirchDowns},
      {"birch_downs", AirEquation::kEdlenBirchDowns},
      {"edlen_birch_downs", AirEquation::kEdlenBirchDowns},
  };
  std::string expected;
  for (const auto& s : kSpellings) {
    if (text == s.name) return s.equation;
    expected += (expected.empty() ? "" : ", ") + std::string(s.name);
  }
  throw InputError(std::string(where) + ": unknown refractive-index equation '" + std::string(text) +
                   "' (expected one of: " + expected + ")");
}

RefractiveIndex AirRefractiveIndex(AirEquation equation, const AirConditions& air, std::string_view where,
                                   RangingIndex index) {
  const double sigma2 = CheckPhysical(air, where);
  // Seed one derivative direction per environmental input.
  const Dual t(air.temperature, 4, 0);
  const Dual p(air.pressure, 4, 1);
  const Dual h(air.humidity, 4, 2);
  const Dual co2(air.co2, 4, 3);
  const Dual n = Evaluate(equation, sigma2, index, t, p, h, co2);
  RefractiveIndex result;
  result.n = n.value();
  result.dn_dtemperature = n.derivatives()(0);
  result.dn_dpressure = n.derivatives()(1);
  result.dn_dhumidity = n.derivatives()(2);
  result.dn_dco2 = n.derivatives()(3);
  for (double v :
       {result.n, result.dn_dtemperature, result.dn_dpressure, result.dn_dhumidity, result.dn_dco2}) {
    CheckFinite(v, where);
  }
  return result;
}

double AirRefractiveIndexValue(AirEquation equation, const AirConditions& air, std::string_view where,
                               RangingIndex index) {
  const double sigma2 = CheckPhysical(air, where);
  const double n = Evaluate(equation, sigma2, index, air.temperature, air.pressure, air.humidity, air.co2);
  CheckFinite(n, where);
  return n;
}

std::string AirValidityProblem(AirEquation equation, const AirConditions& air, std::string_view where) {
  CheckPhysical(air, where);
  const bool ciddor = equation == AirEquation::kCiddor;
  const std::string eq = ciddor                                      ? "Ciddor"
                         : equation == AirEquation::kEdlenBirchDowns ? "modified Edlen (NIST, Birch-Downs)"
                                                                     : "Edlen (Boensch-Potulski)";
  std::string problem;
  const auto check = [&](double value, double lo, double hi, const char* what, double scale,
                         const char* unit) {
    if (problem.empty() && (value < lo || value > hi)) {
      problem = std::string(where) + ": " + what + " " + Num(value * scale) + " " + unit +
                " is outside the range of validity of the " + eq + " equation (" + Num(lo * scale) + ".." +
                Num(hi * scale) + " " + unit + ", NIST Engineering Metrology Toolbox)";
    }
  };
  check(air.vacuum_wavelength, ciddor ? 300e-9 : 350e-9, ciddor ? 1700e-9 : 650e-9, "vacuum wavelength", 1e9,
        "nm");
  check(air.temperature, ciddor ? -40.0 : 0.0, ciddor ? 100.0 : 40.0, "temperature", 1.0, "degC");
  check(air.pressure, ciddor ? 10e3 : 60e3, 140e3, "pressure", 1e-3, "kPa");
  // The modified Edlén equation has no CO2 input (its standard air holds 450 umol/mol): the CO2
  // estimate neither enters n nor is checked against a range it does not have.
  if (equation != AirEquation::kEdlenBirchDowns) {
    check(air.co2, 0.0, 2000e-6, "CO2 mole fraction", 1e6, "umol/mol");
  }
  return problem;
}

void CheckAirValidity(AirEquation equation, const AirConditions& air, std::string_view where) {
  const std::string problem = AirValidityProblem(equation, air, where);
  if (!problem.empty()) throw InputError(problem);
}

double SaturationVapourPressure(double temperature_degc) {
  if (!std::isfinite(temperature_degc) || temperature_degc <= -kZeroCelsius) {
    throw std::invalid_argument("SaturationVapourPressure: temperature must be above -273.15 degC");
  }
  return Svp(temperature_degc);
}

AirIndexReport AirIndexWithUncertainty(AirEquation equation, const AirConditions& estimates,
                                       const double u[4], std::string_view where) {
  AirIndexReport r;
  const RefractiveIndex phase = AirRefractiveIndex(equation, estimates, where, RangingIndex::kPhase);
  const RefractiveIndex group = AirRefractiveIndex(equation, estimates, where, RangingIndex::kGroup);
  r.n_phase = phase.n;
  r.n_group = group.n;
  const double d_phase[4] = {phase.dn_dtemperature, phase.dn_dpressure, phase.dn_dhumidity, phase.dn_dco2};
  const double d_group[4] = {group.dn_dtemperature, group.dn_dpressure, group.dn_dhumidity, group.dn_dco2};
  double var_phase = 0.0, var_group = 0.0;
  for (int k = 0; k < 4; ++k) {
    var_phase += d_phase[k] * d_phase[k] * u[k] * u[k];
    var_group += d_group[k] * d_group[k] * u[k] * u[k];
  }
  r.u_phase = std::sqrt(var_phase);
  r.u_group = std::sqrt(var_group);
  return r;
}

}  // namespace vlt
