// 256-entry colour-map tables (display-encoded sRGB in [0, 1]); see colormap_tables.cpp.
#pragma once

#include <array>

namespace shadefit::metrics::internal {

extern const std::array<std::array<float, 3>, 256> kViridisTable;
extern const std::array<std::array<float, 3>, 256> kMagmaTable;

}  // namespace shadefit::metrics::internal
