// The fit's enum names (fit_types.h, encoding_search.h): each table names every value once, the
// Parse and Name functions read it both ways, and an unknown name is refused with the known ones.
#include <gtest/gtest.h>

#include <set>
#include <string>

#include "shadefit/fit/encoding_search.h"
#include "shadefit/fit/fit_types.h"
#include "shadefit/fit/option_checks.h"

namespace shadefit::fit {
namespace {

// Values 0 .. N-1 of a table of N entries each appear once, with distinct names.
template <typename E, std::size_t N>
void ExpectOneNameEach(const EnumName<E> (&names)[N]) {
  std::set<std::string_view> seen;
  for (std::size_t i = 0; i < N; ++i) {
    const std::string_view name = NameOf(names, static_cast<E>(i));
    EXPECT_NE(name, "?") << "value " << i;
    EXPECT_TRUE(seen.insert(name).second) << name;
    EXPECT_EQ(ValueOf(names, name), static_cast<E>(i)) << name;
  }
}

TEST(NamesTest, EveryValueHasOneName) {
  ExpectOneNameEach(kLossNames);
  ExpectOneNameEach(kPathNames);
  ExpectOneNameEach(kExposureNames);
  ExpectOneNameEach(kSolverNames);
  ExpectOneNameEach(kTerminationNames);
  ExpectOneNameEach(kEncodingModeNames);
}

TEST(NamesTest, ParseAndNameAreInverse) {
  for (const auto& [value, name] : kLossNames) {
    EXPECT_EQ(ParseLoss(std::string(name)), value);
    EXPECT_EQ(LossName(value), name);
  }
  for (const auto& [value, name] : kPathNames) {
    EXPECT_EQ(ParsePath(std::string(name)), value);
    EXPECT_EQ(PathName(value), name);
  }
  for (const auto& [value, name] : kExposureNames) {
    EXPECT_EQ(ParseExposure(std::string(name)), value);
    EXPECT_EQ(ExposureName(value), name);
  }
  for (const auto& [value, name] : kSolverNames) EXPECT_EQ(ParseSolver(std::string(name)), value);
  for (const auto& [value, name] : kEncodingModeNames) {
    EXPECT_EQ(ParseEncodingMode(std::string(name)), value);
    EXPECT_EQ(EncodingModeName(value), name);
  }
  EXPECT_EQ(TerminationName(Termination::kNoConvergence), "NO_CONVERGENCE");
  // The names the fit JSON and study files have always used.
  EXPECT_EQ(LossName(Loss::kCubeRoot), "cuberoot");
  EXPECT_EQ(ExposureName(Exposure::kFree), "free");
}

TEST(NamesTest, UnknownNameListsTheKnownOnes) {
  try {
    ParseLoss("cube-root");
    FAIL() << "no error";
  } catch (const FitOptionError& e) {
    EXPECT_EQ(e.field, FitField::kLoss);
    EXPECT_NE(e.problem.find("unknown loss 'cube-root'"), std::string::npos) << e.problem;
    EXPECT_NE(e.problem.find("known: l2, log, cuberoot, huber, cauchy, relative"),
              std::string::npos)
        << e.problem;
  }
  EXPECT_THROW(ParseSolver("lm"), FitOptionError);
}

}  // namespace
}  // namespace shadefit::fit
