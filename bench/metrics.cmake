# Included by bench/CMakeLists.txt: the metrics benchmark (docs/metrics.md, "Performance").
add_executable(metrics_bench ${CMAKE_CURRENT_LIST_DIR}/metrics_bench.cpp)
target_link_libraries(metrics_bench PRIVATE shadefit::metrics benchmark::benchmark_main)
