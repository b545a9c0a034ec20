# Every dependency comes from a Debian 12 package; the README's first command installs them.
find_package(Threads REQUIRED)
find_package(PkgConfig REQUIRED)
find_package(Ceres 2.1 REQUIRED)
find_package(OpenImageIO REQUIRED)
find_package(OpenEXR REQUIRED)  # image.cpp reads plain EXR files directly
find_package(glm REQUIRED)
# OpenCV's core and imgproc (the sphere finder of imported pictures, reference_images/src/
# auto_sphere.cpp; the colour bar's labels of the error maps, metrics/src/false_color.cpp), as
# Debian's libopencv-core-dev and libopencv-imgproc-dev install them. Not find_package(OpenCV):
# its config file comes only with libopencv-dev, which installs every OpenCV module's
# development package (video I/O, DNN, VTK's viz, ...): 77 more packages, 76 MB to download and
# 412 MB installed on a fresh Debian 12 (docs/testing.md, "What the quick start installs").
find_path(SHADEFIT_OPENCV_INCLUDE_DIR opencv2/core.hpp PATH_SUFFIXES opencv4 REQUIRED)
foreach(module core imgproc)
  find_library(SHADEFIT_OPENCV_${module} opencv_${module} REQUIRED)
  add_library(opencv_${module} UNKNOWN IMPORTED)
  set_target_properties(opencv_${module} PROPERTIES
    IMPORTED_LOCATION "${SHADEFIT_OPENCV_${module}}"
    INTERFACE_INCLUDE_DIRECTORIES "${SHADEFIT_OPENCV_INCLUDE_DIR}")
endforeach()
set_target_properties(opencv_imgproc PROPERTIES INTERFACE_LINK_LIBRARIES opencv_core)
find_package(tomlplusplus REQUIRED)
find_package(nlohmann_json 3.10 REQUIRED)
find_package(fmt REQUIRED)
find_package(CLI11 REQUIRED)
find_package(HDF5 REQUIRED COMPONENTS C)
find_package(OpenSSL 3 REQUIRED COMPONENTS Crypto)  # SHA-256 through EVP (base/src/files.cpp)
pkg_check_modules(EPOXY REQUIRED IMPORTED_TARGET epoxy)
pkg_check_modules(EGL REQUIRED IMPORTED_TARGET egl)
# Surface objects (render/): meshes read by Assimp (OBJ, PLY, glTF and more in one well-kept
# library; docs/scenes.md says why), ray cast by Embree, normals from .mat files by matio; the
# depth integration uses Eigen's sparse Cholesky (Eigen also comes with Ceres).
find_package(assimp REQUIRED)
find_package(embree 3 REQUIRED)
find_package(Eigen3 REQUIRED NO_MODULE)
pkg_check_modules(MATIO REQUIRED IMPORTED_TARGET matio)
if(BUILD_TESTING)
  find_package(GTest REQUIRED)
endif()
if(SHADEFIT_BUILD_BENCH)
  find_package(benchmark REQUIRED)
endif()
