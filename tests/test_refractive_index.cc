// test_refractive_index.cc — refractive index of air against published values, its derivatives
// against central finite differences, and refusals of impossible inputs.
#include "vlt/refractive_index.h"

#include <cmath>
#include <limits>
#include <stdexcept>

#include <gtest/gtest.h>

#include "vlt/error.h"

namespace vlt {
namespace {

AirConditions NistPoint() {
  AirConditions air;
  air.vacuum_wavelength = 633e-9;
  air.temperature = 20.0;
  air.pressure = 101325.0;
  air.humidity = 50.0;
  air.co2 = 450e-6;
  return air;
}

TEST(SaturationVapourPressure, IapwsValues) {
  // IAPWS-IF97 verification table 35: p_s(300 K) = 0.353658941e-2 MPa,
  // p_s(500 K) = 0.263889776e1 MPa.
  EXPECT_NEAR(SaturationVapourPressure(300.0 - 273.15), 3536.58941, 1e-4);
  EXPECT_NEAR(SaturationVapourPressure(500.0 - 273.15), 2.63889776e6, 1.0);
  // Triple point 273.16 K: 611.657 Pa from both the water and the ice formula (IAPWS 2011).
  EXPECT_NEAR(SaturationVapourPressure(0.01), 611.657, 0.01);
  // At 0 degC (273.15 K) ice: 611.15 Pa; the water formula gives 611.21 Pa, so switching
  // formulas at 0 degC leaves a step of only 0.06 Pa (1e-11 in n).
  EXPECT_NEAR(SaturationVapourPressure(-1e-12), 611.154, 0.005);
  EXPECT_NEAR(SaturationVapourPressure(0.0), 611.213, 0.005);
  // IAPWS 2011 sublimation: p_subl(253.15 K) = 103.26 Pa (NIST toolbox tabulates 103.3 Pa).
  EXPECT_NEAR(SaturationVapourPressure(-20.0), 103.26, 0.05);
  EXPECT_THROW(SaturationVapourPressure(-300.0), std::invalid_argument);
}

TEST(RefractiveIndex, CiddorNistCheckValue) {
  // NIST Engineering Metrology Toolbox, Ciddor equation: n = 1.000271373 at 633 nm, 20 degC,
  // 101325 Pa, 50 % RH, 450 umol/mol CO2 (reference README section 3).
  const RefractiveIndex r = AirRefractiveIndex(AirEquation::kCiddor, NistPoint());
  EXPECT_NEAR(r.n, 1.000271373, 1e-9);
  EXPECT_DOUBLE_EQ(AirRefractiveIndexValue(AirEquation::kCiddor, NistPoint()), r.n);
}

TEST(RefractiveIndex, CiddorOtherConditions) {
  // Values printed in the README of P. Nair's `ref_index` 1.0 (PyPI; an independent
  // implementation of the NIST toolbox equations), 633 nm, 450 umol/mol CO2. The NIST calculator
  // itself prints 9 decimals; these agree with it and test humidity, 60 degC and 100 kPa.
  struct Case {
    double t, p, rh, n;
  };
  const Case cases[] = {
      {20.0, 101325.0, 20.0, 1.0002716285340578},
      {20.0, 101325.0, 80.0, 1.0002711183472626},
      {60.0, 101325.0, 80.0, 1.0002340241754055},
      {15.0, 101325.0, 0.0, 633.0 / 632.82500476826874},   // vac2air(633.0)
      {20.0, 100000.0, 50.0, 633.0 / 632.83051710791892},  // vac2air(633, t=20, p=1e5, rh=50)
  };
  for (const Case& c : cases) {
    AirConditions air = NistPoint();
    air.temperature = c.t;
    air.pressure = c.p;
    air.humidity = c.rh;
    EXPECT_NEAR(AirRefractiveIndexValue(AirEquation::kCiddor, air), c.n, 1e-10)
        << c.t << " degC " << c.p << " Pa " << c.rh << " %";
  }
}

TEST(RefractiveIndex, CiddorStandardAirDispersion) {
  // At Ciddor's standard conditions (15 degC, 101325 Pa, dry, 450 umol/mol) the density ratio is
  // 1 and n - 1 must equal the dispersion formula (Ciddor eq. 1) exactly.
  AirConditions air;
  air.temperature = 15.0;
  air.pressure = 101325.0;
  air.humidity = 0.0;
  air.co2 = 450e-6;
  for (double lambda_um : {0.4, 0.633, 1.0, 1.55}) {
    air.vacuum_wavelength = lambda_um * 1e-6;
    const double s2 = 1.0 / (lambda_um * lambda_um);
    const double expected = 0.05792105 / (238.0185 - s2) + 0.00167917 / (57.362 - s2);
    EXPECT_NEAR(AirRefractiveIndexValue(AirEquation::kCiddor, air) - 1.0, expected, 1e-12)
        << lambda_um;
  }
}

TEST(RefractiveIndex, EdlenStandardAirAndCiddorAgreement) {
  // Bönsch & Potulski eq. (6)-(8) at their standard air (20 degC, 100 kPa, dry, 400 umol/mol):
  // the density factor p [1 + ...] / (93214.60 (1 + 0.003661 t)) is 1 to 3e-7 relative, so n - 1
  // equals the dispersion formula (n-1)_N to 1e-10.
  AirConditions air;
  air.vacuum_wavelength = 633e-9;
  air.temperature = 20.0;
  air.pressure = 100000.0;
  air.humidity = 0.0;
  air.co2 = 400e-6;
  const double s2 = 1.0 / (0.633 * 0.633);
  const double n_n1 = 1e-8 * (8091.37 + 2333983.0 / (130.0 - s2) + 15518.0 / (38.9 - s2));
  EXPECT_NEAR(AirRefractiveIndexValue(AirEquation::kEdlenBoensch, air) - 1.0, n_n1, 1e-10);

  // No published value of the Bönsch-Potulski equation at the NIST check point was found (the
  // NIST calculator's Edlén is the Birch-Downs variant with a different water term). The two
  // equations differ at this point by 1.6e-8 (0.9e-8 dry-air part, 0.6e-8 water-vapour term),
  // within their combined stated uncertainties (about 1e-8 each); check that level of agreement.
  const double edlen = AirRefractiveIndexValue(AirEquation::kEdlenBoensch, NistPoint());
  const double ciddor = AirRefractiveIndexValue(AirEquation::kCiddor, NistPoint());
  EXPECT_NEAR(edlen, ciddor, 2e-8);
  EXPECT_NEAR(edlen, 1.000271373, 2e-8);
  AirConditions dry = NistPoint();
  dry.humidity = 0.0;
  EXPECT_NEAR(AirRefractiveIndexValue(AirEquation::kEdlenBoensch, dry),
              AirRefractiveIndexValue(AirEquation::kCiddor, dry), 1.2e-8);
}

// Central finite differences of the value path, step h.
RefractiveIndex FiniteDifferences(AirEquation eq, const AirConditions& air) {
  const auto n = [&](AirConditions a) { return AirRefractiveIndexValue(eq, a); };
  RefractiveIndex fd;
  fd.n = n(air);
  AirConditions a = air, b = air;
  a.temperature += 1e-3, b.temperature -= 1e-3;
  fd.dn_dtemperature = (n(a) - n(b)) / 2e-3;
  a = air, b = air;
  a.pressure += 1.0, b.pressure -= 1.0;
  fd.dn_dpressure = (n(a) - n(b)) / 2.0;
  a = air, b = air;
  a.humidity += 0.1, b.humidity -= 0.1;
  fd.dn_dhumidity = (n(a) - n(b)) / 0.2;
  a = air, b = air;
  a.co2 += 10e-6, b.co2 -= 10e-6;
  fd.dn_dco2 = (n(a) - n(b)) / 20e-6;
  return fd;
}

TEST(RefractiveIndex, DerivativesMatchFiniteDifferences) {
  for (AirEquation eq : {AirEquation::kCiddor, AirEquation::kEdlenBoensch}) {
    for (double t : {-10.0, 5.0, 20.0, 35.0}) {
      if (eq == AirEquation::kEdlenBoensch && t < 0.0) continue;
      for (double lambda : {633e-9, 1550e-9}) {
        AirConditions air = NistPoint();
        air.temperature = t;
        air.vacuum_wavelength = lambda;
        air.humidity = 40.0;
        const RefractiveIndex ad = AirRefractiveIndex(eq, air);
        const RefractiveIndex fd = FiniteDifferences(eq, air);
        // Finite differences of n ~ 1 carry ~1e-16/h rounding: relative 1e-5 is what they can
        // resolve here; a wrong derivative would be off by far more.
        EXPECT_NEAR(ad.dn_dtemperature, fd.dn_dtemperature, 1e-5 * std::abs(fd.dn_dtemperature));
        EXPECT_NEAR(ad.dn_dpressure, fd.dn_dpressure, 1e-5 * std::abs(fd.dn_dpressure));
        EXPECT_NEAR(ad.dn_dhumidity, fd.dn_dhumidity, 1e-5 * std::abs(fd.dn_dhumidity));
        EXPECT_NEAR(ad.dn_dco2, fd.dn_dco2, 1e-5 * std::abs(fd.dn_dco2));
      }
    }
  }
}

TEST(RefractiveIndex, SensitivitiesNearReferenceReadme) {
  // Reference README section 3: dn/dt ~ -9.5e-7 /K, dn/dp ~ +2.7e-9 /Pa, dn/dRH ~ -8.5e-9 /%RH.
  for (AirEquation eq : {AirEquation::kCiddor, AirEquation::kEdlenBoensch}) {
    const RefractiveIndex r = AirRefractiveIndex(eq, NistPoint());
    EXPECT_NEAR(r.dn_dtemperature, -9.5e-7, 0.3e-7);
    EXPECT_NEAR(r.dn_dpressure, 2.7e-9, 0.05e-9);
    EXPECT_NEAR(r.dn_dhumidity, -8.5e-9, 0.5e-9);
    // CO2: (n-1) * 0.53 per unit mole fraction ~ 1.45e-4.
    EXPECT_NEAR(r.dn_dco2, 0.000271 * 0.534, 0.1e-4);
  }
}

TEST(RefractiveIndex, RefusesImpossibleInputs) {
  const auto bad = [](auto mutate) {
    AirConditions air = NistPoint();
    mutate(air);
    return air;
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const AirConditions cases[] = {
      bad([](AirConditions& a) { a.pressure = -1.0; }),
      bad([](AirConditions& a) { a.pressure = 0.0; }),
      bad([](AirConditions& a) { a.humidity = -0.1; }),
      bad([](AirConditions& a) { a.humidity = 100.1; }),
      bad([&](AirConditions& a) { a.temperature = nan; }),
      bad([&](AirConditions& a) { a.pressure = inf; }),
      bad([](AirConditions& a) { a.temperature = -300.0; }),
      bad([](AirConditions& a) { a.vacuum_wavelength = 0.0; }),
      bad([](AirConditions& a) { a.co2 = -1e-6; }),
      bad([&](AirConditions& a) { a.co2 = nan; }),
  };
  for (const AirConditions& air : cases) {
    for (AirEquation eq : {AirEquation::kCiddor, AirEquation::kEdlenBoensch}) {
      EXPECT_THROW(AirRefractiveIndex(eq, air, "job.toml: environment"), InputError);
      EXPECT_THROW(AirRefractiveIndexValue(eq, air, "job.toml: environment"), InputError);
    }
  }
  try {
    AirRefractiveIndex(AirEquation::kCiddor, cases[2], "job.toml: environment.humidity");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("job.toml: environment.humidity: ", 0), 0u);
  }
}

TEST(RefractiveIndex, ValidityRangeAndNames) {
  EXPECT_NO_THROW(CheckAirValidity(AirEquation::kCiddor, NistPoint(), "w"));
  EXPECT_NO_THROW(CheckAirValidity(AirEquation::kEdlenBoensch, NistPoint(), "w"));
  AirConditions ir = NistPoint();
  ir.vacuum_wavelength = 1550e-9;
  EXPECT_NO_THROW(CheckAirValidity(AirEquation::kCiddor, ir, "w"));
  EXPECT_THROW(CheckAirValidity(AirEquation::kEdlenBoensch, ir, "w"), InputError);
  AirConditions hot = NistPoint();
  hot.temperature = 120.0;
  EXPECT_THROW(CheckAirValidity(AirEquation::kCiddor, hot, "w"), InputError);
  // Outside validity but physical: the evaluation itself still works (Monte Carlo tails).
  EXPECT_NO_THROW(AirRefractiveIndex(AirEquation::kCiddor, hot));

  EXPECT_EQ(ParseAirEquation("ciddor", "w"), AirEquation::kCiddor);
  EXPECT_EQ(ParseAirEquation("edlen", "w"), AirEquation::kEdlenBoensch);
  EXPECT_EQ(AirEquationName(AirEquation::kCiddor), "ciddor");
  EXPECT_THROW(ParseAirEquation("owens", "w"), InputError);
}

TEST(RefractiveIndex, DispersionPoleIsNumericalError) {
  // sigma^2 = 130 um^-2 is a pole of the Edlén dispersion term: lambda = 1/sqrt(130) um.
  AirConditions air = NistPoint();
  air.vacuum_wavelength = 1e-6 / std::sqrt(130.0);
  try {
    const double n = AirRefractiveIndexValue(AirEquation::kEdlenBoensch, air);
    EXPECT_TRUE(std::isfinite(n));  // if rounding misses the pole the value is finite
  } catch (const NumericalError&) {
  }
}

}  // namespace
}  // namespace vlt

namespace vlt {
namespace {

TEST(AirIndexReport, GroupIndexOfEdlenBoenschAgainstTheAnalyticDispersion) {
  // Bönsch & Potulski: (n-1)_N 1e8 = 8091.37 + 2333983/(130 - s^2) + 15518/(38.9 - s^2), s = 1/lambda
  // [1/um]; at fixed t, p, x (dry air) n - 1 = F (n-1)_N with F independent of lambda, so
  // n_g - n = -lambda dn/dlambda = s dn/ds = F 1e-8 (2 * 2333983 s^2/(130 - s^2)^2 + 2 * 15518 s^2/(38.9 - s^2)^2).
  AirConditions air;
  air.vacuum_wavelength = 633e-9;
  air.temperature = 20.0;
  air.pressure = 101325.0;
  air.humidity = 0.0;
  air.co2 = 400e-6;
  const double u[4] = {0.1, 10.0, 5.0, 50e-6};
  const AirIndexReport r = AirIndexWithUncertainty(AirEquation::kEdlenBoensch, air, u);
  const double s2 = std::pow(1.0 / 0.633, 2);
  const double n_minus_1_n = 1e-8 * (8091.37 + 2333983.0 / (130.0 - s2) + 15518.0 / (38.9 - s2));
  const double f = (r.n_phase - 1.0) / n_minus_1_n;
  const double expected = f * 1e-8 * (2.0 * 2333983.0 * s2 / std::pow(130.0 - s2, 2) + 2.0 * 15518.0 * s2 / std::pow(38.9 - s2, 2));
  EXPECT_NEAR(r.n_group - r.n_phase, expected, 1e-6 * expected);
  // u(n): the root sum of squares of the exact sensitivities times u (independent inputs).
  const RefractiveIndex n = AirRefractiveIndex(AirEquation::kEdlenBoensch, air);
  const double u_phase = std::sqrt(std::pow(n.dn_dtemperature * u[0], 2) + std::pow(n.dn_dpressure * u[1], 2) +
                                   std::pow(n.dn_dhumidity * u[2], 2) + std::pow(n.dn_dco2 * u[3], 2));
  EXPECT_NEAR(r.u_phase, u_phase, 1e-12 * u_phase);
  // In dry air with only temperature and pressure uncertain, n - 1 and n_g - 1 are both F(t, p)
  // times a function of the wavelength: u(n_g)/(n_g - 1) = u(n)/(n - 1) exactly.
  const double u_tp[4] = {0.1, 10.0, 0.0, 0.0};
  const AirIndexReport d = AirIndexWithUncertainty(AirEquation::kEdlenBoensch, air, u_tp);
  const double relative = d.u_phase / (d.n_phase - 1.0);
  EXPECT_NEAR(d.u_group / (d.n_group - 1.0), relative, 2e-4 * relative);  // finite differences of n_g
}

}  // namespace
}  // namespace vlt
