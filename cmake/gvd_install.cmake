# What `cmake --install build --prefix P` puts under P (docs/CPP.md):
#   lib/libgvd_api.a, libgvd_core.a, libgvd_kernels.a   the facade, the engine, OpenCL backend
#   include/gvd/...                                     gvd/gvd.h (stable) and the internal headers
#   lib/cmake/gvd/gvdConfig*.cmake, gvdTargets*.cmake   find_package(gvd 0.2) -> gvd::core
#   lib/pkgconfig/gvd.pc                                pkg-config --cflags --libs gvd
#   bin/gvd, bin/gvd-server, share/gvd/web              (clients/, server/, clients/web/)
# Exported targets: gvd::core (the facade gvd_api, linking everything below), gvd::engine
# (gvd_core, internal headers), gvd::kernels (gvd_kernels, the OpenCL backend). The libraries
# are static, so the config finds what they link: Threads, TinyGLTF and OpenCL (the ICD
# loader libOpenCL.so.1; without an OpenCL platform at run time gvd::api::compute's "auto"
# backend computes on the CPU).
include(CMakePackageConfigHelpers)

set(GVD_CMAKE_INSTALL_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/gvd)

install(TARGETS gvd_api gvd_core gvd_kernels EXPORT gvdTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/core/include/gvd ${PROJECT_SOURCE_DIR}/kernels/include/gvd
                  ${PROJECT_SOURCE_DIR}/api/include/gvd
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} FILES_MATCHING PATTERN "*.h")
install(EXPORT gvdTargets NAMESPACE gvd:: DESTINATION ${GVD_CMAKE_INSTALL_DIR})

configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/gvdConfig.cmake.in
                              ${CMAKE_CURRENT_BINARY_DIR}/gvdConfig.cmake
                              INSTALL_DESTINATION ${GVD_CMAKE_INSTALL_DIR})
# 0.x: a new minor version may break the API (gvd/gvd.h), so only 0.MINOR.* satisfies a
# request for 0.MINOR.
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/gvdConfigVersion.cmake
                                 VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/gvdConfig.cmake
              ${CMAKE_CURRENT_BINARY_DIR}/gvdConfigVersion.cmake
        DESTINATION ${GVD_CMAKE_INSTALL_DIR})

# gvd.pc finds its prefix from its own place (${pcfiledir}), so the tree can be moved.
file(RELATIVE_PATH GVD_PC_TO_PREFIX /prefix/${CMAKE_INSTALL_LIBDIR}/pkgconfig /prefix)
string(REGEX REPLACE "/$" "" GVD_PC_TO_PREFIX "${GVD_PC_TO_PREFIX}")
configure_file(${CMAKE_CURRENT_LIST_DIR}/gvd.pc.in ${CMAKE_CURRENT_BINARY_DIR}/gvd.pc @ONLY)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/gvd.pc
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
