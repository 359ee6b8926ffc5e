// test_units.cc — every unit factor against its independent definition, and every refusal.
#include "vlt/units.h"

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "vlt/error.h"

namespace vlt {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr const char* kWhere = "job.toml: tracker.noise.azimuth";

double Parse(std::string_view text, Dimension d) { return ParseQuantity(text, d, kWhere); }

// The message of the InputError thrown by ParseQuantity, or "" when it does not throw.
std::string ErrorOf(std::string_view text, Dimension d) {
  try {
    Parse(text, d);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(Units, LengthFactors) {
  EXPECT_DOUBLE_EQ(Parse("12 um", Dimension::kLength), 12e-6);
  EXPECT_DOUBLE_EQ(Parse("12um", Dimension::kLength), 12e-6);
  EXPECT_DOUBLE_EQ(Parse("12 \xC2\xB5m", Dimension::kLength), 12e-6);  // micro sign
  EXPECT_DOUBLE_EQ(Parse("12 \xCE\xBCm", Dimension::kLength), 12e-6);  // Greek mu
  EXPECT_DOUBLE_EQ(Parse("3.5 mm", Dimension::kLength), 3.5e-3);
  EXPECT_DOUBLE_EQ(Parse("633 nm", Dimension::kLength), 633e-9);
  EXPECT_DOUBLE_EQ(Parse("2 cm", Dimension::kLength), 0.02);
  EXPECT_DOUBLE_EQ(Parse("1.5 km", Dimension::kLength), 1500.0);
  EXPECT_DOUBLE_EQ(Parse("10 in", Dimension::kLength), 0.254);  // 1 in = 25.4 mm exactly
  EXPECT_DOUBLE_EQ(Parse("4.2 m", Dimension::kLength), 4.2);
  EXPECT_DOUBLE_EQ(Parse("4.2", Dimension::kLength), 4.2);  // bare number is SI
  EXPECT_DOUBLE_EQ(Parse("  -1.25e-3 m \t", Dimension::kLength), -1.25e-3);
  EXPECT_DOUBLE_EQ(Parse("+7E2 mm", Dimension::kLength), 0.7);
  EXPECT_DOUBLE_EQ(Parse(".5 m", Dimension::kLength), 0.5);
}

TEST(Units, AngleFactors) {
  // Definitions: 1 deg = pi/180 rad, 1' = 1 deg/60, 1" = 1'/60, 1 gon = pi/200 rad.
  EXPECT_DOUBLE_EQ(Parse("1 arcsec", Dimension::kAngle), kPi / 648000.0);
  EXPECT_NEAR(Parse("1 arcsec", Dimension::kAngle), 4.84813681109536e-6, 1e-20);
  EXPECT_DOUBLE_EQ(Parse("0.8 arcsec", Dimension::kAngle), 0.8 * kPi / 180.0 / 3600.0);
  EXPECT_DOUBLE_EQ(Parse("1 arcmin", Dimension::kAngle), kPi / 180.0 / 60.0);
  EXPECT_DOUBLE_EQ(Parse("180 deg", Dimension::kAngle), kPi);
  EXPECT_DOUBLE_EQ(Parse("90\xC2\xB0", Dimension::kAngle), kPi / 2.0);
  EXPECT_DOUBLE_EQ(Parse("400 gon", Dimension::kAngle), 2.0 * kPi);
  EXPECT_DOUBLE_EQ(Parse("1 mgon", Dimension::kAngle), kPi / 200000.0);
  EXPECT_DOUBLE_EQ(Parse("2 urad", Dimension::kAngle), 2e-6);
  EXPECT_DOUBLE_EQ(Parse("2 \xC2\xB5rad", Dimension::kAngle), 2e-6);
  EXPECT_DOUBLE_EQ(Parse("3 mrad", Dimension::kAngle), 3e-3);
  EXPECT_DOUBLE_EQ(Parse("5 nrad", Dimension::kAngle), 5e-9);
  EXPECT_DOUBLE_EQ(Parse("0.25 rad", Dimension::kAngle), 0.25);
}

TEST(Units, RatioFractionHumidity) {
  EXPECT_DOUBLE_EQ(Parse("0.5 ppm", Dimension::kRatio), 0.5e-6);
  EXPECT_DOUBLE_EQ(Parse("0.5 um/m", Dimension::kRatio), 0.5e-6);
  EXPECT_DOUBLE_EQ(Parse("0.5 \xC2\xB5m/m", Dimension::kRatio), 0.5e-6);
  EXPECT_DOUBLE_EQ(Parse("2 mm/m", Dimension::kRatio), 2e-3);
  EXPECT_DOUBLE_EQ(Parse("3 nm/m", Dimension::kRatio), 3e-9);
  EXPECT_DOUBLE_EQ(Parse("3 ppb", Dimension::kRatio), 3e-9);
  EXPECT_DOUBLE_EQ(Parse("1 %", Dimension::kRatio), 0.01);
  EXPECT_DOUBLE_EQ(Parse("1e-6 m/m", Dimension::kRatio), 1e-6);
  EXPECT_DOUBLE_EQ(Parse("1e-6 1", Dimension::kRatio), 1e-6);

  EXPECT_DOUBLE_EQ(Parse("450 umol/mol", Dimension::kFraction), 450e-6);
  EXPECT_DOUBLE_EQ(Parse("450 ppm", Dimension::kFraction), 450e-6);
  EXPECT_DOUBLE_EQ(Parse("450 \xCE\xBCmol/mol", Dimension::kFraction), 450e-6);
  EXPECT_DOUBLE_EQ(Parse("0.045 %", Dimension::kFraction), 450e-6);
  EXPECT_DOUBLE_EQ(Parse("0.00045", Dimension::kFraction), 450e-6);

  // Relative humidity stays in percent: "45 %" -> 45.
  EXPECT_DOUBLE_EQ(Parse("45 %", Dimension::kHumidity), 45.0);
  EXPECT_DOUBLE_EQ(Parse("45 % RH", Dimension::kHumidity), 45.0);
  EXPECT_DOUBLE_EQ(Parse("45", Dimension::kHumidity), 45.0);
  EXPECT_DOUBLE_EQ(Parse("1", Dimension::kDimensionless), 1.0);
}

TEST(Units, TemperatureAndPressure) {
  EXPECT_DOUBLE_EQ(Parse("20 degC", Dimension::kTemperature), 20.0);
  EXPECT_DOUBLE_EQ(Parse("20 \xC2\xB0"
                         "C",
                         Dimension::kTemperature),
                   20.0);
  EXPECT_NEAR(Parse("293.15 K", Dimension::kTemperature), 20.0, 1e-12);  // t = T - 273.15 K
  EXPECT_NEAR(Parse("0 K", Dimension::kTemperature), -273.15, 1e-12);
  EXPECT_DOUBLE_EQ(Parse("0.1 K", Dimension::kTemperatureDifference), 0.1);
  EXPECT_DOUBLE_EQ(Parse("0.1 degC", Dimension::kTemperatureDifference), 0.1);
  EXPECT_DOUBLE_EQ(Parse("50 mK", Dimension::kTemperatureDifference), 0.05);

  EXPECT_DOUBLE_EQ(Parse("1013.25 hPa", Dimension::kPressure), 101325.0);
  EXPECT_DOUBLE_EQ(Parse("1013.25 mbar", Dimension::kPressure), 101325.0);
  EXPECT_DOUBLE_EQ(Parse("101.325 kPa", Dimension::kPressure), 101325.0);
  EXPECT_DOUBLE_EQ(Parse("1.01325 bar", Dimension::kPressure), 101325.0);
  EXPECT_DOUBLE_EQ(Parse("0.101325 MPa", Dimension::kPressure), 101325.0);
  EXPECT_DOUBLE_EQ(Parse("760 Torr", Dimension::kPressure), 101325.0);  // 1 atm = 760 Torr
  // Conventional mmHg = 13.5951 g/cm^3 * 9.80665 m/s^2 * 1 mm.
  EXPECT_NEAR(Parse("1 mmHg", Dimension::kPressure), 13595.1 * 9.80665 * 1e-3, 1e-9);
}

TEST(Units, PerKelvinAndTime) {
  EXPECT_DOUBLE_EQ(Parse("11.5 ppm/K", Dimension::kPerKelvin), 11.5e-6);
  EXPECT_DOUBLE_EQ(Parse("11.5 um/m/K", Dimension::kPerKelvin), 11.5e-6);
  EXPECT_DOUBLE_EQ(Parse("11.5e-6 1/K", Dimension::kPerKelvin), 11.5e-6);
  EXPECT_DOUBLE_EQ(Parse("11.5e-6 /K", Dimension::kPerKelvin), 11.5e-6);
  EXPECT_DOUBLE_EQ(Parse("23 ppm/degC", Dimension::kPerKelvin), 23e-6);
  EXPECT_DOUBLE_EQ(Parse("23 \xC2\xB5m/m/\xC2\xB0"
                         "C",
                         Dimension::kPerKelvin),
                   23e-6);
  EXPECT_DOUBLE_EQ(Parse("2 min", Dimension::kTime), 120.0);
  EXPECT_DOUBLE_EQ(Parse("1.5 h", Dimension::kTime), 5400.0);
  EXPECT_DOUBLE_EQ(Parse("250 ms", Dimension::kTime), 0.25);
  EXPECT_DOUBLE_EQ(Parse("250 us", Dimension::kTime), 250e-6);
}

TEST(Units, WrongDimensionNamesBoth) {
  // (Built with +=: GCC 12 warns falsely on std::string(...) + "long literal" at -O1.)
  std::string expected = kWhere;
  expected += ": '12 arcsec' is an angle, expected a length (m, mm, um, nm, cm, km, in)";
  EXPECT_EQ(ErrorOf("12 arcsec", Dimension::kLength), expected);
  EXPECT_NE(ErrorOf("12 um", Dimension::kAngle).find("is a length, expected an angle"), std::string::npos);
  EXPECT_NE(ErrorOf("20 hPa", Dimension::kTemperature).find("is a pressure"), std::string::npos);
  EXPECT_NE(ErrorOf("5 ppm/K", Dimension::kRatio).find("is an expansion coefficient"), std::string::npos);
  EXPECT_NE(ErrorOf("1 s", Dimension::kLength).find("is a time"), std::string::npos);
}

TEST(Units, RefusesMalformedUnknownNonFinite) {
  for (const char* bad : {"", "   ", "abc", "um", "1..2 m", "1e m", "1e+ mm", "inf", "nan", "-inf m", "NaN",
                          "1,5 mm", "1e999 m", "m 12"}) {
    const std::string msg = ErrorOf(bad, Dimension::kLength);
    EXPECT_FALSE(msg.empty()) << "accepted '" << bad << "'";
    EXPECT_EQ(msg.rfind(kWhere, 0), 0u) << msg;  // message starts with the file and key
  }
  EXPECT_NE(ErrorOf("12 furlong", Dimension::kLength).find("unknown unit 'furlong'"), std::string::npos);
  EXPECT_NE(ErrorOf("12 Um", Dimension::kLength).find("unknown unit"), std::string::npos);
  // Overflow in the conversion itself.
  EXPECT_FALSE(ErrorOf("1e306 km", Dimension::kLength).empty());
  // Absolute temperature below 0 K.
  EXPECT_NE(ErrorOf("-1 K", Dimension::kTemperature).find("below absolute zero"), std::string::npos);
  EXPECT_NE(ErrorOf("-300 degC", Dimension::kTemperature).find("below absolute zero"), std::string::npos);
  // A difference may be negative.
  EXPECT_DOUBLE_EQ(Parse("-1 K", Dimension::kTemperatureDifference), -1.0);
}

// A decimal number too small for a double reads as its correctly rounded value, 0 (as strtod and
// Python give; base/decimal.h), never -0; one too large is refused; the smallest subnormal reads.
TEST(Units, NumbersBelowTheSmallestDoubleAreZero) {
  for (const char* tiny : {"1e-400 m", "-1e-400 m", "2e-324 m", "0.00001e-320 m", "123456e-335 m", "1e-99999999999999999999 m",
                           "-0.000e-5000 m", "1e-400"}) {
    const double v = Parse(tiny, Dimension::kLength);
    EXPECT_EQ(v, 0.0) << tiny;
    EXPECT_FALSE(std::signbit(v)) << tiny;
  }
  EXPECT_EQ(Parse("3e-324 m", Dimension::kLength), 4.9406564584124654e-324);  // the least subnormal
  EXPECT_EQ(Parse("1e-300 um", Dimension::kLength), 1e-306);
  for (const char* huge : {"1e400 m", "-1e309 m", "0.001e312 m", "12345e305 m", "1e99999999999999999999 m"}) {
    EXPECT_NE(ErrorOf(huge, Dimension::kLength).find("out of the range of finite numbers"), std::string::npos) << huge;
  }
}

TEST(Units, FormatRoundTrips) {
  EXPECT_EQ(FormatQuantity(12e-6, Dimension::kLength, "um"), "12 um");
  EXPECT_EQ(FormatQuantity(101325.0, Dimension::kPressure, "hPa"), "1013.25 hPa");
  EXPECT_EQ(FormatQuantity(20.0, Dimension::kTemperature, "K"), "293.15 K");
  EXPECT_EQ(FormatQuantity(0.5, Dimension::kLength), "0.5 m");
  EXPECT_NEAR(FromSi(kPi / 648000.0, Dimension::kAngle, "arcsec"), 1.0, 1e-15);
  EXPECT_DOUBLE_EQ(ToSi(1.0, Dimension::kAngle, "arcsec"), kPi / 648000.0);
  for (Dimension d :
       {Dimension::kLength, Dimension::kAngle, Dimension::kRatio, Dimension::kTemperature,
        Dimension::kTemperatureDifference, Dimension::kPressure, Dimension::kHumidity, Dimension::kFraction,
        Dimension::kPerKelvin, Dimension::kDimensionless, Dimension::kTime}) {
    ASSERT_FALSE(AcceptedUnits(d).empty());
    for (std::string_view unit : AcceptedUnits(d)) {
      const double si = 1.2345678901234 * (d == Dimension::kTemperature ? 10.0 : 1.0);
      const std::string text = FormatQuantity(si, d, unit, 17);
      EXPECT_NEAR(ParseQuantity(text, d, kWhere), si, 1e-14 * std::abs(si)) << text;
    }
    EXPECT_FALSE(DimensionName(d).empty());
    EXPECT_FALSE(SiUnit(d).empty());
  }
  EXPECT_THROW(FromSi(1.0, Dimension::kLength, "arcsec"), std::invalid_argument);
}

// What the user typed is shown back (UncertainInput::display_*): the unit after the number.
TEST(Units, TypedUnitAndReadableFormat) {
  EXPECT_EQ(TypedUnit("0.4 arcsec"), "arcsec");
  EXPECT_EQ(TypedUnit(" -1.5e-3  um/m "), "um/m");
  EXPECT_EQ(TypedUnit("22.3degC"), "degC");
  EXPECT_EQ(TypedUnit("12"), "");
  EXPECT_EQ(TypedUnit("1e3 hPa"), "hPa");
  // Readable: below 1 mm in µm, a gauge in mm with every digit; small angles in arcsec.
  EXPECT_EQ(FormatReadable(12e-6, Dimension::kLength), "12 µm");
  EXPECT_EQ(FormatReadable(0.050000623, Dimension::kLength), "50.000623 mm");
  EXPECT_EQ(FormatReadable(ToSi(0.35, Dimension::kAngle, "arcsec"), Dimension::kAngle), "0.35 arcsec");
  EXPECT_EQ(FormatReadable(ToSi(20, Dimension::kAngle, "deg"), Dimension::kAngle), "20 deg");
  EXPECT_EQ(FormatReadable(101325.0, Dimension::kPressure), "1013.25 hPa");
  EXPECT_EQ(FormatReadable(11.5e-6, Dimension::kPerKelvin), "11.5 ppm/K");
}

}  // namespace
}  // namespace vlt
