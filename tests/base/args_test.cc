// base/args: the one command-line parser. A macro's typo is refused with the option's name,
// never ignored; numbers are whole and finite or refused.

#include "mlp/base/args.h"

#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace mlp::base {
namespace {

const ArgSpec kSpec = {{"--probe", "--seed", "--rpm"}, {"--json"}, {"--finish"}};

std::string ErrorOf(const std::vector<std::string>& args, const ArgSpec& spec = kSpec) {
  try {
    const Args a(args, spec);
    a.Number("--rpm", 0.0);
    a.Integer("--seed", 1, 1);
  } catch (const UsageError& e) {
    return e.what();
  }
  return "";
}

TEST(Args, ReadsValuesSwitchesAndRepeatedOptions) {
  const Args a({"--probe", "p.json", "--json", "--finish", "matt", "--rpm", "1200.5", "--finish",
                "ground_steel:8"},
               kSpec);
  EXPECT_EQ(a.Text("--probe"), "p.json");
  EXPECT_TRUE(a.Has("--json"));
  EXPECT_FALSE(a.Has("--seed"));
  EXPECT_EQ(a.Integer("--seed", 7), 7);
  EXPECT_EQ(a.Text("--seed", "none"), "none");
  EXPECT_DOUBLE_EQ(a.Number("--rpm"), 1200.5);
  EXPECT_EQ(a.All("--finish"), (std::vector<std::string>{"matt", "ground_steel:8"}));
  EXPECT_TRUE(a.All("--other").empty());
}

TEST(Args, RefusesWhatTheCommandDoesNotTakeNamingIt) {
  EXPECT_NE(ErrorOf({"--prboe", "p.json"}).find("--prboe"), std::string::npos);
  EXPECT_NE(ErrorOf({"--probe"}).find("--probe needs a value"), std::string::npos);
  EXPECT_NE(ErrorOf({"--probe", "a", "--probe", "b"}).find("twice"), std::string::npos);
  EXPECT_NE(ErrorOf({"stray"}).find("stray"), std::string::npos);  // no positionals here
}

TEST(Args, NumbersAreWholeAndFiniteOrRefused) {
  for (const std::string bad : {"12x", "", "nan", "inf", "1e999"})
    EXPECT_NE(ErrorOf({"--rpm", bad}).find("--rpm needs a number"), std::string::npos) << bad;
  for (const std::string bad : {"0", "1.5", "-3", "99999999999999999999999"})
    EXPECT_NE(ErrorOf({"--seed", bad}).find("--seed needs a whole number >= 1"), std::string::npos)
        << bad;
  EXPECT_EQ(ErrorOf({"--rpm", "-0.25", "--seed", "3"}), "");
}

TEST(Args, ARequiredValueThatIsMissingIsNamed) {
  const Args a({}, kSpec);
  try {
    a.Text("--probe");
    FAIL() << "no error";
  } catch (const UsageError& e) {
    EXPECT_EQ(std::string(e.what()), "--probe is required");
  }
}

TEST(Args, PositionalsOnlyWhereTheCommandTakesThem) {
  const ArgSpec spec{{"--units"}, {"--text"}, {}, true};
  const Args a({"sphere", "--units", "m", "-", "--text"}, spec);
  EXPECT_EQ(a.Positionals(), (std::vector<std::string>{"sphere", "-"}));  // "-" is stdin
  EXPECT_EQ(a.Text("--units"), "m");
  EXPECT_NE(ErrorOf({"-x"}, spec).find("-x"), std::string::npos);
}

TEST(Args, ANumberListIsFiniteNumbersBetweenCommas) {
  EXPECT_EQ(ParseNumberList("--xy", "0.03,-1e-2"), (std::vector<double>{0.03, -0.01}));
  EXPECT_EQ(ParseNumberList("--xy", "7"), (std::vector<double>{7}));
  for (const char* bad : {"", "1,,2", "1,x", "1,nan", "1;2"})
    EXPECT_THROW(ParseNumberList("--xy", bad), UsageError) << bad;
}

}  // namespace
}  // namespace mlp::base
