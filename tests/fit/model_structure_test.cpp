// The model-structure analysis the bounded LM relies on (fit/src/model_structure.h), held against
// what each model's formulas in render/models say.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "shadefit/render/models.h"
#include "../../fit/src/model_structure.h"  // Internal to fit/.

namespace shadefit {
namespace {

// What the solver reads of each model's structure, against what the formulas say: that no
// shipped model mixes colour channels (cycles-principled has no tint: its specular tint is 0),
// and which entries the radiance is affine in (variable projection's linear block).
TEST(ModelStructure, SeparableChannelsAndLinearEntries) {
  using fit::internal::ChannelSeparable;
  using fit::internal::LinearEntries;
  EXPECT_TRUE(ChannelSeparable(FindModel("ggx").id));
  EXPECT_TRUE(ChannelSeparable(FindModel("blinn-phong").id));
  EXPECT_TRUE(ChannelSeparable(FindModel("ggx-metallic").id));
  EXPECT_TRUE(ChannelSeparable(FindModel("cycles-principled").id));
  auto linear_names = [](const std::string& name) {
    const ModelInfo& model = FindModel(name);
    const std::vector<bool> linear = LinearEntries(model.id);
    std::string out;
    for (int i = 0; i < model.ParamCount(); ++i) {
      if (!linear[i]) continue;
      if (!out.empty()) out += ' ';
      out += model.EntryName(i);
    }
    return out;
  };
  // f = kd / pi + D V F_Schlick(f0): affine in kd and f0 (Schlick's F is), not in roughness.
  EXPECT_EQ(linear_names("ggx"), "kd.r kd.g kd.b f0.r f0.g f0.b");
  EXPECT_EQ(linear_names("lambert"), "kd.r kd.g kd.b");
  // base_color (1 - metallic) and mix(f0_dielectric, base_color, metallic): bilinear in base and
  // metallic, so the first row is kept, with f0_dielectric (affine jointly with base).
  EXPECT_EQ(linear_names("ggx-metallic"), "base_color.r base_color.g base_color.b f0_dielectric");
}

// Which row each term reads (the Jacobian pass's per-term Jets), against the formulas in
// render/models: ggx's Diffuse kd / pi, Fresnel F_Schlick(f0), Lobe D V (roughness); classic
// Blinn-Phong's kd, ks and cos^n (its ka is the Ambient term, not one of the three); Lambert has
// no Fresnel or Lobe row; ggx-metallic's Diffuse reads base_color and metallic, so it keeps the
// full Jet.
TEST(ModelStructure, EachTermReadsTheRowsOfItsFormula) {
  using fit::internal::RowsOfTerms;
  auto rows = [](const std::string& name) {
    const fit::internal::TermRows& t = RowsOfTerms(FindModel(name).id);
    return std::vector<int>{t.single ? 1 : 0, t.diffuse, t.fresnel, t.lobe};
  };
  EXPECT_EQ(rows("ggx"), (std::vector<int>{1, 0, 1, 2}));
  EXPECT_EQ(rows("blinn-phong"), (std::vector<int>{1, 1, 2, 3}));
  EXPECT_EQ(rows("lambert"), (std::vector<int>{1, 0, -1, -1}));
  EXPECT_FALSE(RowsOfTerms(FindModel("ggx-metallic").id).single);
}

// Models with more than one row per term: ggx-2lobe's lobe reads roughness, spread and w, so it
// keeps the full Jet; it is affine in kd and f0, and in w alone, but F(f0) times the lobe makes
// f0 and w bilinear, so w (after f0 in table order) is not kept. Classic Blinn-Phong is affine
// in ka, kd and ks jointly (ka amb + kd n.l + ks (n.h)^n), not in its exponent.
TEST(ModelStructure, TwoLobeAndClassicModels) {
  using fit::internal::LinearEntries;
  using fit::internal::RowsOfTerms;
  const fit::internal::TermRows& two = RowsOfTerms(FindModel("ggx-2lobe").id);
  EXPECT_FALSE(two.single);
  EXPECT_EQ(two.diffuse, 0);
  EXPECT_EQ(two.fresnel, 1);
  auto linear_count = [](const std::string& name) {
    const std::vector<bool> linear = LinearEntries(FindModel(name).id);
    return static_cast<int>(std::count(linear.begin(), linear.end(), true));
  };
  const std::vector<bool> two_linear = LinearEntries(FindModel("ggx-2lobe").id);
  const ModelInfo& m = FindModel("ggx-2lobe");
  EXPECT_TRUE(two_linear[m.Offset("kd")] && two_linear[m.Offset("f0") + 2]);
  EXPECT_FALSE(two_linear[m.Offset("w")]);
  EXPECT_FALSE(two_linear[m.Offset("roughness")]);
  EXPECT_EQ(linear_count("ggx-2lobe"), 6);
  EXPECT_EQ(linear_count("blinn-phong"), 9);
  EXPECT_TRUE(fit::internal::ChannelSeparable(FindModel("ggx-2lobe").id));
}

}  // namespace
}  // namespace shadefit
