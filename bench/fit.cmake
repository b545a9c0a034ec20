# Included by bench/CMakeLists.txt: fitting speed (docs/fitting.md, BENCHMARKS.md).
add_executable(fit_bench ${CMAKE_CURRENT_LIST_DIR}/fit_bench.cpp)
target_link_libraries(fit_bench PRIVATE shadefit::fit benchmark::benchmark_main)
