# Included by bench/CMakeLists.txt: the probes benchmark (docs/probes.md, "Performance").
add_executable(probes_bench ${CMAKE_CURRENT_LIST_DIR}/probes_bench.cpp)
target_link_libraries(probes_bench PRIVATE shadefit::probes benchmark::benchmark_main)
