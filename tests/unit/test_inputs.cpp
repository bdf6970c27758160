// Unit checks of the input layer: material coefficients, inflow series, scene validation.
#include "granflow/core/channel.hpp"
#include "granflow/core/material.hpp"
#include "granflow/params/parameters.hpp"
#include "granflow/scene/scene.hpp"

#include <Teuchos_XMLParameterListHelpers.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>

using namespace granflow;

TEST(Material, EarthPressureCoefficientsOfThePapersMaterial) {
  // phi = 33, delta = 22 deg: K = 2 sec^2(phi) (1 -/+ sqrt(1 - cos^2 phi sec^2 delta)) - 1,
  // evaluated independently here: cos^2(33) = 0.703368, sec^2(22) = 1.163237,
  // sqrt(1 - 0.818185) = 0.426398, sec^2(33) = 1.421733.
  core::Material m;
  m.internal_friction_deg = 33;
  m.bed_friction_deg = 22;
  // 1e-5: the hand-evaluated constants above carry 6-7 significant digits.
  EXPECT_NEAR(m.K_active(), 2 * 1.421733 * (1 - 0.426398) - 1, 1e-5);
  EXPECT_NEAR(m.K_passive(), 2 * 1.421733 * (1 + 0.426398) - 1, 1e-5);
}

TEST(Material, DeltaEqualPhiGivesEqualActiveAndPassive) {
  // At delta = phi the square root vanishes: K_act = K_pas = 2 sec^2(phi) - 1 (round-off only).
  core::Material m;
  m.internal_friction_deg = 30;
  m.bed_friction_deg = 30;
  EXPECT_NEAR(m.K_active(), m.K_passive(), 1e-12);
  EXPECT_NEAR(m.K_active(), 2.0 / std::pow(std::cos(M_PI / 6), 2) - 1.0, 1e-12);
}

TEST(Material, DeltaAbovePhiIsRejectedWithParameterNameAndValue) {
  Teuchos::ParameterList pl(*core::Material::getValidParameters());
  pl.setName("granflow->Material");
  pl.set("Internal friction angle", 30.0);
  pl.set("Bed friction angle", 35.0);
  try {
    core::Material::from_parameters(pl);
    FAIL() << "delta > phi accepted";
  } catch (const params::InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("Bed friction angle' = 35"), std::string::npos) << msg;
    EXPECT_NE(msg.find("delta <= phi"), std::string::npos) << msg;
  }
}

namespace {
std::string write_tmp(const std::string& name, const std::string& text) {
  const std::string f = ::testing::TempDir() + name;
  std::ofstream(f) << text;
  return f;
}
}  // namespace

TEST(InflowSeries, InterpolatesLinearlyAndHoldsTheEnds) {
  const auto f = write_tmp("series_ok.csv", "t,h,u\n0,0.0,0.5\n1,0.1,1.5\n3,0.1,0.5\n");
  const auto s = core::InflowSeries::from_csv(f, "p");
  // Exact arithmetic on these values; 1e-14 allows for round-off of the interpolation weight.
  EXPECT_NEAR(s.depth(0.5), 0.05, 1e-14);
  EXPECT_NEAR(s.velocity(2.0), 1.0, 1e-14);
  EXPECT_NEAR(s.depth(-1.0), 0.0, 1e-14);  // before the first row: first value
  EXPECT_NEAR(s.velocity(10.0), 0.5, 1e-14);  // after the last row: last value
}

// The volume that enters in [t0, t1] is the integral of h u: piecewise, h and u are linear, h u
// quadratic, and Simpson's rule between the rows is exact. Checked against the integral done by
// hand for the series below: on [0, 1] h = 0.1 t, u = 0.5 + t, int h u = 0.1 (1/4 + 1/3) =
// 0.0583333...; on [1, 3] h = 0.1, u = 1.5 - (t - 1)/2, int = 0.1 (3 - 1) = 0.2; beyond the last
// row the last values hold (0.1 x 0.5 per second). Round-off of a few products: 1e-15.
TEST(InflowSeries, DischargeIsTheExactIntegralOfDepthTimesVelocity) {
  const auto f = write_tmp("series_q.csv", "t,h,u\n0,0.0,0.5\n1,0.1,1.5\n3,0.1,0.5\n");
  const auto s = core::InflowSeries::from_csv(f, "p");
  EXPECT_NEAR(s.discharge(0.0, 1.0), 0.1 * (0.25 + 1.0 / 3.0), 1e-15);
  EXPECT_NEAR(s.discharge(1.0, 3.0), 0.2, 1e-15);
  EXPECT_NEAR(s.discharge(0.0, 5.0), 0.1 * (0.25 + 1.0 / 3.0) + 0.2 + 0.1, 1e-15);
  // across rows, and additive however the interval is cut (what a step sequence does)
  const double whole = s.discharge(0.3, 2.7);
  double parts = 0.0, a = 0.3;
  for (double b : {0.35, 0.999, 1.0, 1.7, 2.7}) {
    parts += s.discharge(a, b);
    a = b;
  }
  EXPECT_NEAR(parts, whole, 1e-15);
  EXPECT_EQ(s.discharge(2.0, 2.0), 0.0);
  EXPECT_EQ(s.discharge(2.0, 1.0), 0.0);
  // a constant gate: h u (t1 - t0)
  EXPECT_NEAR(core::InflowSeries(0.06, 0.37).discharge(0.0, 0.5), 0.06 * 0.37 * 0.5, 1e-16);
}

TEST(InflowSeries, RejectsNonIncreasingTimesAndNegativeDepthNamingTheLine) {
  const auto f1 = write_tmp("series_bad_t.csv", "0,0.1,1\n0,0.1,1\n");
  EXPECT_THROW(core::InflowSeries::from_csv(f1, "p"), params::InputError);
  const auto f2 = write_tmp("series_bad_h.csv", "0,0.1,1\n1,-0.1,1\n");
  try {
    core::InflowSeries::from_csv(f2, "granflow->Channel->Left boundary->Inflow series file");
    FAIL() << "negative depth accepted";
  } catch (const params::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("line 2"), std::string::npos) << e.what();
  }
}

// A series is refused like the constant inflow (depth > 0 needs a velocity > 0): a negative
// velocity on any row (material leaving through the gate) and a row with h > 0 and u = 0 name
// the file, the line and the values; u = 0 with h = 0 (gate closed) is accepted.
TEST(InflowSeries, RejectsVelocitiesOutOfTheChannelNamingTheLine) {
  const std::string p = "granflow->Channel->Left boundary->Inflow series file";
  for (const char* text : {"0,0.06,0.37\n1,0.06,-0.2\n", "0,0,0.3\n1,0,-0.1\n",
                           "0,0.06,0.37\n0.5,0.06,0\n"}) {
    const auto f = write_tmp("series_bad_u.csv", text);
    try {
      core::InflowSeries::from_csv(f, p);
      FAIL() << "accepted: " << text;
    } catch (const params::InputError& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find(p), std::string::npos) << m;
      EXPECT_NE(m.find("line 2"), std::string::npos) << m;
      EXPECT_NE(m.find("velocity u = "), std::string::npos) << m;
      EXPECT_NE(m.find("allowed: u >= 0"), std::string::npos) << m;
    }
  }
  const auto ok = write_tmp("series_gate_closes.csv", "0,0.06,0.37\n1,0.06,0.37\n1.1,0,0\n");
  EXPECT_NO_THROW(core::InflowSeries::from_csv(ok, p));
  // a series that starts after t = 0 is refused (it said nothing about the start of the run)
  const auto late = write_tmp("series_late.csv", "0.5,0.06,0.37\n1,0.06,0.37\n");
  try {
    core::InflowSeries::from_csv(late, p);
    FAIL() << "a series from t = 0.5 s accepted";
  } catch (const params::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("the first row is at t = 0.5 s; allowed: a first row at t <= 0"),
              std::string::npos)
        << e.what();
  }
}

TEST(Scene, EveryShippedSceneValidatesAndBuilds) {
  for (const char* s : {"setup1_dam.xml", "setup2_dam.xml", "dambreak_incline.xml"}) {
    const auto scene = scene::load(std::string(GRANFLOW_INPUTS) + "/" + s);
    auto model = scene::build_model(scene);
    ASSERT_TRUE(model);
    EXPECT_EQ(model->model_name(), "DAM") << s;
    EXPECT_GT(model->stable_dt(), 0.0) << s;
  }
}

// --- strict values (issue 13): a scene's text is one number or an error, never another number
TEST(StrictValues, DoublesAreTheWholeTextInDecimalNotation) {
  // Accepted texts convert to exactly the double strtod gives for the same text (== on doubles:
  // the conversion is the same correctly rounded one).
  for (const char* t : {"0.25", "1e-3", "1E+3", ".5", "5.", "-0", "+2", " 7 ", "89", "1e-300"}) {
    double v = -1.0;
    std::string why;
    ASSERT_TRUE(params::parse_double(t, v, why)) << t << ": " << why;
    EXPECT_EQ(v, std::strtod(t, nullptr)) << t;
  }
  for (const char* t : {"", " ", "abc", "50abc", "0x10", "nan", "inf", "-infinity", "1e999",
                        "1e-400", "1,5", "1.5.2", "e5", "1e", "--1", "{0.5}", "0.5 0.7"}) {
    double v = 123.0;
    std::string why;
    EXPECT_FALSE(params::parse_double(t, v, why)) << t;
    EXPECT_EQ(v, 123.0) << t << ": value changed on failure";
    EXPECT_FALSE(why.empty()) << t;
  }
}

TEST(StrictValues, IntegersAreIntegralAndFitAnInt) {
  const std::pair<const char*, int> ok[] = {
      {"400", 400}, {"-5", -5}, {"+3", 3}, {" 12 ", 12}, {"2147483647", 2147483647},
      {"-2147483648", -2147483647 - 1}};
  for (const auto& [t, want] : ok) {
    int v = 0;
    std::string why;
    ASSERT_TRUE(params::parse_int(t, v, why)) << t << ": " << why;
    EXPECT_EQ(v, want) << t;
  }
  // 4294967696 = 2^32 + 400 wrapped to 400 before; 50.9 was truncated to 50, 8x read as 8.
  for (const char* t : {"4294967696", "2147483648", "50.9", "50.0", "1e3", "8x", "abc", "", "0x10",
                        "99999999999999999999"}) {
    int v = 7;
    std::string why;
    EXPECT_FALSE(params::parse_int(t, v, why)) << t;
    EXPECT_EQ(v, 7) << t;
  }
}

TEST(StrictValues, BoolsAndText) {
  bool b = false;
  std::string why;
  EXPECT_TRUE(params::parse_bool("true", b, why) && b);
  EXPECT_TRUE(params::parse_bool("false", b, why) && !b);
  for (const char* t : {"1", "yes", "True", "", "truex"}) EXPECT_FALSE(params::parse_bool(t, b, why)) << t;
  // UTF-8: accented letters, degree sign, tab kept; invalid bytes, overlong forms, surrogates,
  // truncated sequences and control characters refused.
  for (const char* t : {"setup2_dam", "D\xc3\xa9j\xc3\xa0 vu", "50 \xc2\xb0", "a\tb", ""})
    EXPECT_TRUE(params::check_text(t, why)) << t << ": " << why;
  for (const char* t : {"setup2\xff_dam", "\xc0\xaf", "\xed\xa0\x80", "\xe2\x82", "a\x01" "b",
                        "\xf4\x90\x80\x80"})
    EXPECT_FALSE(params::check_text(t, why)) << t;
  // Messages show such bytes as \xNN, so that the message itself is valid text.
  EXPECT_EQ(params::shown("setup2\xff_dam"), "\"setup2\\xff_dam\"");
  EXPECT_EQ(params::shown("D\xc3\xa9j\xc3\xa0"), "\"D\xc3\xa9j\xc3\xa0\"");
}

// A line break in a string (&#10; in the XML) is refused by name, except in the free text of
// 'Description' (a hostile-user run named a scene "a&#10;b": its log lines broke in two).
TEST(StrictValues, LineBreaksOnlyInTheDescription) {
  const auto ok = write_tmp("multiline_description.xml",
                            "<ParameterList name=\"granflow\">"
                            "<Parameter name=\"Description\" type=\"string\" value=\"two&#10;lines\"/>"
                            "</ParameterList>");
  EXPECT_EQ(params::read_xml(ok)->get<std::string>("Description"), "two\nlines");
  for (const char* value : {"a&#10;b", "a&#13;b"}) {
    const auto bad = write_tmp("multiline_name.xml",
                               std::string("<ParameterList name=\"granflow\">"
                                           "<Parameter name=\"Name\" type=\"string\" value=\"") +
                                   value + "\"/></ParameterList>");
    try {
      params::read_xml(bad);
      FAIL() << value << " accepted";
    } catch (const params::InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("parameter 'granflow->Name'"), std::string::npos) << what;
      EXPECT_NE(what.find("contains a line break (at position 2)"), std::string::npos) << what;
    }
  }
}

// XML's numeric character references in any form: Teuchos' reader made &#233; the byte 0xE9
// (then refused as not UTF-8) and did not take &#xE9; or code points above 255 (a hostile-user
// run: a Name written with entities). They are now the UTF-8 text they stand for; a reference
// to '<' stays a character of the value, and one to a character XML does not allow (a
// surrogate) is refused.
TEST(StrictValues, CharacterReferencesAreTheirCharacters) {
  auto name_of = [](const std::string& value) {
    const auto f = write_tmp("charref.xml",
                             "<ParameterList name=\"granflow\"><Parameter name=\"Name\" "
                             "type=\"string\" value=\"" + value + "\"/></ParameterList>");
    return params::read_xml(f)->get<std::string>("Name");
  };
  EXPECT_EQ(name_of("a&#233;b"), "a\xc3\xa9" "b");
  EXPECT_EQ(name_of("a&#xE9;b&#xe9;"), "a\xc3\xa9" "b\xc3\xa9");
  EXPECT_EQ(name_of("&#x100;&#x20AC;&#x1F600;"), "\xc4\x80\xe2\x82\xac\xf0\x9f\x98\x80");
  EXPECT_EQ(name_of("a&#x41;&#65;&#x3C;b"), "aAA<b");
  EXPECT_EQ(name_of("a\xc3\xa9" "b"), "a\xc3\xa9" "b");  // literal UTF-8 as before
  EXPECT_THROW(name_of("a&#xD800;b"), params::InputError);
}

TEST(StrictValues, ShippedScenesReadAsTeuchosReadsThem) {
  // For valid input the strict reader must give the same list as Teuchos's own XML reader
  // (same names, types and values, compared exactly): it only refuses what Teuchos misreads.
  for (const char* s : {"setup1_dam.xml", "setup2_dam.xml", "dambreak_incline.xml",
                        "setup1_ndam.xml", "setup2_ndam.xml", "setup2_coupled.xml",
                        "setup2_split_1d.xml", "ndam_cavity_re100.xml", "ndam_rest_slope.xml"}) {
    const std::string file = std::string(GRANFLOW_INPUTS) + "/" + s;
    const auto strict = params::read_xml(file);
    const auto teuchos = Teuchos::getParametersFromXmlFile(file);
    EXPECT_TRUE(Teuchos::haveSameValues(*strict, *teuchos)) << s;
  }
  // the comparison sees a difference: Setup I and Setup II differ in their channel
  EXPECT_FALSE(Teuchos::haveSameValues(
      *params::read_xml(std::string(GRANFLOW_INPUTS) + "/setup1_dam.xml"),
      *Teuchos::getParametersFromXmlFile(std::string(GRANFLOW_INPUTS) + "/setup2_dam.xml")));
}

TEST(InflowSeries, RowsAreThreeStrictNumbers) {
  const auto f1 = write_tmp("series_trailing.csv", "t,h,u\n0,0.06,0.37\n0.5,0.06abc,0.37\n");
  const auto f2 = write_tmp("series_four.csv", "t,h,u\n0,0.06,0.37\n0.5,0.06,0.37,4\n");
  const auto f3 = write_tmp("series_nan.csv", "0,0.06,0.37\n0.5,nan,0.37\n");
  for (const auto& f : {f1, f2, f3}) {
    try {
      core::InflowSeries::from_csv(f, "p");
      FAIL() << f << " accepted";
    } catch (const params::InputError& e) {
      EXPECT_NE(std::string(e.what()).find("line "), std::string::npos) << e.what();
    }
  }
  // blanks instead of commas and CRLF line ends are still read
  const auto ok = write_tmp("series_blank.csv", "t h u\r\n0 0.06 0.37\r\n1 0.08 0.5\r\n");
  EXPECT_NEAR(core::InflowSeries::from_csv(ok, "p").depth(0.5), 0.07, 1e-15);  // round-off only
}

// A header names the columns in the order they are read, t,h,u (a unit may follow a name): a
// file headed t,u,h had its velocities read as depths without a word (a hostile-user run), and
// so did a header of two names over three columns. A UTF-8 byte-order mark before the first
// line is dropped, so a first data row behind it is read, not taken for a header.
TEST(InflowSeries, HeaderMustNameTheColumnsInTheirOrder) {
  for (const char* header : {"t,u,h", "foo,bar", "time,depth,velocity", "t,h", "h,t,u"}) {
    const auto f = write_tmp("series_header.csv", std::string(header) + "\n0,0.06,0.37\n1,0.06,0.37\n");
    try {
      core::InflowSeries::from_csv(f, "p");
      FAIL() << header << " accepted";
    } catch (const params::InputError& e) {
      EXPECT_NE(std::string(e.what()).find("neither data nor the header t,h,u"), std::string::npos)
          << e.what();
    }
  }
  for (const char* header : {"t,h,u", "T, H, U", "t [s],h [m],u [m/s]", "t(s) h(m) u(m/s)"}) {
    const auto f = write_tmp("series_header.csv", std::string(header) + "\n0,0.06,0.37\n1,0.08,0.5\n");
    const auto s = core::InflowSeries::from_csv(f, "p");
    EXPECT_EQ(s.depth(1.0), 0.08) << header;  // the second column is h
  }
  const auto bom = write_tmp("series_bom.csv", "\xEF\xBB\xBF" "0,0.06,0.37\n1,0.08,0.5\n");
  EXPECT_EQ(core::InflowSeries::from_csv(bom, "p").depth(0.0), 0.06);  // the first row is data
}
