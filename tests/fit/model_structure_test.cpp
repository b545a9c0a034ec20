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

// Every model's linear entries and whether its radiance is linear (zero at zero) in them, against
// the formulas in render/models. Lafortune is the case a weak probe got wrong: its lobe
// [C_xy (l_x v_x + l_y v_y) + C_z l_z v_z]^n is not linear in C_z, but at exponents of 30-70 it
// was too small for the differences to show, and C_z was solved as a linear entry.
TEST(ModelStructure, EveryModelsLinearEntriesAndHomogeneity) {
  std::string table;
  for (const ModelInfo& model : AllModels()) {
    const std::vector<bool> linear = fit::internal::LinearEntries(model.id);
    std::string rows;
    for (const ParamSpec& row : model.params) {
      if (!linear[model.Offset(row.name)]) continue;
      rows += (rows.empty() ? "" : " ") + row.name;
      for (int c = 1; c < row.size; ++c) {
        EXPECT_TRUE(linear[model.Offset(row.name) + c]) << model.name << " " << row.name;
      }
    }
    table += model.name + ": " + rows +
             (fit::internal::HomogeneousInLinearEntries(model.id) ? " (linear)\n" : "\n");
  }
  // From the formulas: Schlick's F is affine in f0 but not zero at f0 = 0, so no ggx-like model
  // is linear; cook-torrance's exact dielectric Fresnel of f0 and ggx-conductor's of (eta, k) are
  // not affine; ashikhmin-shirley's diffuse carries (1 - rs), bilinear with rd; the 2-lobe Cook-
  // Torrance is affine in its lobe weight w.
  EXPECT_EQ(table,
            "lambert: kd (linear)\n"
            "phong: ka kd ks (linear)\n"
            "blinn-phong: ka kd ks (linear)\n"
            "blinn-phong-normalized: kd ks (linear)\n"
            "ggx: kd f0\n"
            "ggx-metallic: base_color f0_dielectric\n"
            "ggx-separable: kd f0\n"
            "ggx-dielectric: kd\n"
            "ggx-conductor: \n"
            "ggx-burley: kd f0\n"
            "beckmann: kd f0\n"
            "cycles-principled: base_color\n"
            "ward: kd ks (linear)\n"
            "ward-duer: kd ks (linear)\n"
            "ashikhmin-shirley: rd\n"
            "lafortune: kd ks (linear)\n"
            "cook-torrance: kd\n"
            "oren-nayar: kd (linear)\n"
            "ggx-2lobe: kd f0\n"
            "cook-torrance-2lobe: kd w\n");
}

}  // namespace
}  // namespace shadefit
