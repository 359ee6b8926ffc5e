// vlt/refractive_index.h — phase refractive index of moist air and its sensitivities.
//
// A laser tracker measures optical path; the range is the optical path divided by the refractive
// index of the air along the beam: the PHASE index n for an interferometer (fringes travel at the
// phase velocity), the GROUP index n_g = n - lambda dn/dlambda for an absolute distance meter
// (its modulation travels at the group velocity; Ciddor & Hill, Appl. Opt. 38 (1999) 1663). The
// measurement model uses the index of the tracker's ranging principle (MeasurementSetup::ranging,
// docs/units.md "Group index").
//
// Three equations (docs/units.md, "Refractive index of air"):
//  - kEdlenBoensch: Edlén's equation as updated by G. Bönsch and E. Potulski, Metrologia 35 (1998)
//    133-139, eqs. (6)-(9) (dispersion, CO2, density, water vapour), with the water-vapour partial
//    pressure from relative humidity through the IAPWS saturation vapour pressure over liquid
//    water (as the NIST Engineering Metrology Toolbox does for its Edlén variant).
//  - kEdlenBirchDowns: the "modified Edlén equation" of the NIST Engineering Metrology Toolbox
//    (J. A. Stone, J. H. Zimmerman, "Index of Refraction of Air", Appendix A-IV): Edlén's equation
//    as updated by K. P. Birch and M. J. Downs, Metrologia 30 (1993) 155 and 31 (1994) 315, with
//    NIST's temperature factor 292.75 K / T on the water-vapour term. Its standard air contains
//    450 umol/mol CO2 and CO2 is NOT an input: dn/dCO2 = 0 whatever the CO2 estimate.
//  - kCiddor: P. E. Ciddor, Appl. Opt. 35 (1996) 1566-1573: BIPM-1981/91 moist-air density with
//    compressibility Z, water vapour mole fraction from the enhancement factor and the IAPWS
//    saturation vapour pressure (over ice below 0 degC), as in the NIST Engineering Metrology
//    Toolbox (J. A. Stone, J. H. Zimmerman, "Index of Refraction of Air", Appendix A).
//
// Derivatives are exact (forward-mode automatic differentiation of the same equations), never
// finite differences.
#pragma once

#include <string_view>

namespace vlt {

enum class AirEquation { kEdlenBoensch, kCiddor, kEdlenBirchDowns };

// Which index: the phase index n, or the group index n_g = n - lambda dn/dlambda, computed exactly
// from each equation's dispersion terms (every equation is linear in them).
enum class RangingIndex { kPhase, kGroup };

// "edlen", "ciddor" or "modified_edlen" (the spellings job files use and results.json writes).
std::string_view AirEquationName(AirEquation equation);
// Inverse of AirEquationName; also accepts the aliases "edlen_boensch", "boensch_potulski"
// (kEdlenBoensch) and "birch_downs", "edlen_birch_downs" (kEdlenBirchDowns). Throws InputError
// "<where>: unknown refractive-index equation '<text>' (expected one of: ciddor, edlen,
// edlen_boensch, boensch_potulski, modified_edlen, birch_downs, edlen_birch_downs)".
AirEquation ParseAirEquation(std::string_view text, std::string_view where);

// Conditions of the air along the beam, SI as everywhere in vlt.
struct AirConditions {
  double vacuum_wavelength = 633e-9;  // m (HeNe: 632.99e-9; typical ADM: 780e-9 .. 1550e-9)
  double temperature = 20.0;          // degC
  double pressure = 101325.0;         // Pa
  double humidity = 50.0;             // relative humidity, % (0..100)
  double co2 = 450e-6;                // CO2 mole fraction, 1 (450e-6 = 450 umol/mol)
};

// n (phase or group) and its partial derivatives with respect to the four environmental inputs.
struct RefractiveIndex {
  double n = 1.0;                // refractive index, 1
  double dn_dtemperature = 0.0;  // 1/K     (about -9.5e-7 /K near 20 degC, 633 nm)
  double dn_dpressure = 0.0;     // 1/Pa    (about +2.7e-9 /Pa)
  double dn_dhumidity = 0.0;     // 1/%RH   (about -8.5e-9 per %RH at 20 degC)
  double dn_dco2 = 0.0;          // 1 per unit mole fraction (about +1.4e-4, i.e. 1.4e-10 per ppm;
                                 // exactly 0 for kEdlenBirchDowns, which has no CO2 input)
};

// Refractive index and derivatives. Throws InputError, message starting with `where`, when an
// input is physically impossible: non-finite value, wavelength <= 0, temperature <= -273.15
// degC, pressure <= 0, humidity outside 0..100 %, CO2 fraction outside [0, 1). Inputs outside the
// equation's published range of validity are NOT refused here (a Monte Carlo trial may wander
// slightly outside); CheckAirValidity does that for the estimates a user gives.
// Throws NumericalError if the result is not finite (e.g. a wavelength on a dispersion pole).
RefractiveIndex AirRefractiveIndex(AirEquation equation, const AirConditions& air,
                                   std::string_view where = "refractive index",
                                   RangingIndex index = RangingIndex::kPhase);

// The refractive index a job reports (results.json inputs.air, docs/units.md "Group index"):
// the phase index n and the group index n_g = n - lambda dn/dlambda (what the pulses or the
// modulation of an absolute distance meter travel with), each with its standard uncertainty from
// the standard uncertainties u[4] of temperature [K], pressure [Pa], humidity [%] and CO2 [1]
// (JCGM 100 5.1.2, independent inputs; dn/dx and dn_g/dx exact by automatic differentiation).
struct AirIndexReport {
  double n_phase = 1.0, u_phase = 0.0;
  double n_group = 1.0, u_group = 0.0;
};
AirIndexReport AirIndexWithUncertainty(AirEquation equation, const AirConditions& estimates,
                                       const double u[4], std::string_view where = "refractive index");

// Only n (same checks): the cheap path for Monte Carlo trials.
double AirRefractiveIndexValue(AirEquation equation, const AirConditions& air,
                               std::string_view where = "refractive index",
                               RangingIndex index = RangingIndex::kPhase);

// Refuses (InputError "<where>: <quantity> <value> is outside the range of validity of the
// <equation> equation (<range>)") conditions outside the published range of validity:
//   Ciddor (NIST):  wavelength 300..1700 nm, temperature -40..100 degC, pressure 10..140 kPa,
//                   humidity 0..100 %, CO2 0..2000 umol/mol;
//   Edlén (NIST / Bönsch-Potulski): wavelength 350..650 nm, temperature 0..40 degC,
//                   pressure 60..140 kPa, humidity 0..100 %, CO2 0..2000 umol/mol;
//   modified Edlén (NIST / Birch-Downs): wavelength 350..650 nm, temperature 0..40 degC,
//                   pressure 60..140 kPa, humidity 0..100 %; CO2 is not checked (not an input).
void CheckAirValidity(AirEquation equation, const AirConditions& air, std::string_view where);
// The same check as a text: "" inside the range of validity, else the message CheckAirValidity
// would throw (conditions that are physically impossible still throw). The readers of job and
// network files warn with it and compute (as NIST's calculator does), and `--strict` fails.
std::string AirValidityProblem(AirEquation equation, const AirConditions& air, std::string_view where);

// Saturation vapour pressure [Pa] at temperature t [degC]: over liquid water by the IAPWS
// industrial formulation (IAPWS-IF97, eq. 30, as the NIST toolbox, Appendix A-I) for t >= 0,
// over ice by the IAPWS 1993 sublimation formula for t < 0 (Ciddor; NIST). All three equations
// use it.
// t must be finite and above -273.15 (else std::invalid_argument).
double SaturationVapourPressure(double temperature_degc);

}  // namespace vlt
