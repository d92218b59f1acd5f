# The installed library end to end (docs/CPP.md): `cmake --install` of this build into a
# fresh prefix, then the consumer project (tests/install/consumer, the example of
# docs/CPP.md) configured with find_package(gvd) against that prefix only, built, and run:
# its checks on two cubes (analytic answers), then its dual graph of a bundled scene compared
# with the installed `gvd compute --graph` on the same scene (byte for byte: the same engine
# with the same options). Last, the same main.cpp compiled with `pkg-config --cflags --libs
# gvd` and run without an OpenCL platform. Nothing of gvd is rebuilt. Invoked with -DBUILD=<build dir> -DSRC=<tests/install>
# -DDATA=<tests/data> -DDOC=<docs/CPP.md> -DOUT=<scratch dir> -DCXX=<compiler>
# -DGENERATOR=<cmake generator> -DNO_OPENCL=<an empty directory (OCL_ICD_VENDORS)>.

function(run what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err
                  WORKING_DIRECTORY ${OUT})
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${what} failed (${rc}):\n${out}\n${err}")
  endif()
  set(out "${out}" PARENT_SCOPE)
endfunction()

set(prefix ${OUT}/prefix)
file(REMOVE_RECURSE ${OUT})
file(MAKE_DIRECTORY ${OUT})

run("cmake --install" ${CMAKE_COMMAND} --install ${BUILD} --prefix ${prefix})
foreach(f include/gvd/gvd.h include/gvd/common/error.h lib/libgvd_api.a lib/libgvd_core.a
          lib/libgvd_kernels.a lib/cmake/gvd/gvdConfig.cmake lib/cmake/gvd/gvdConfigVersion.cmake
          lib/cmake/gvd/gvdTargets.cmake lib/pkgconfig/gvd.pc bin/gvd bin/gvd-server
          share/gvd/web/index.html)
  if(NOT EXISTS ${prefix}/${f})
    message(FATAL_ERROR "cmake --install did not install ${f}")
  endif()
endforeach()

# The consumer: only the prefix is searched (no package registry, no build tree).
run("configuring the consumer" ${CMAKE_COMMAND} -S ${SRC}/consumer -B ${OUT}/consumer -G
    ${GENERATOR} -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER=${CXX}
    -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF)
file(STRINGS ${OUT}/consumer/CMakeCache.txt gvd_dir REGEX "^gvd_DIR:")
if(NOT gvd_dir STREQUAL "gvd_DIR:PATH=${prefix}/lib/cmake/gvd")
  message(FATAL_ERROR "find_package(gvd) found ${gvd_dir}, not the installed prefix")
endif()
run("building the consumer" ${CMAKE_COMMAND} --build ${OUT}/consumer)
run("the consumer on two cubes" ${OUT}/consumer/gvd_example)
message(STATUS "consumer:\n${out}")

set(scene ${DATA}/scenes/balls_on_plate.json)
run("the consumer on ${scene}" ${OUT}/consumer/gvd_example ${scene} ${OUT}/graph_api.json cpu)
run("the installed gvd compute" ${prefix}/bin/gvd compute ${scene} --graph ${OUT}/graph_cli.json
    --backend cpu -q)
execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${OUT}/graph_api.json
                        ${OUT}/graph_cli.json RESULT_VARIABLE differ)
if(differ)
  message(FATAL_ERROR "the library's dual graph of ${scene} differs from gvd compute --graph")
endif()

# pkg-config: a one-file consumer (the same main.cpp).
find_program(PKG_CONFIG pkg-config REQUIRED)
set(ENV{PKG_CONFIG_PATH} ${prefix}/lib/pkgconfig)
run("pkg-config" ${PKG_CONFIG} --cflags --libs gvd)
string(STRIP "${out}" flags)
separate_arguments(flags UNIX_COMMAND "${flags}")
run("compiling with pkg-config" ${CXX} -std=c++20 -O1 ${SRC}/consumer/main.cpp ${flags} -o
    ${OUT}/gvd_example_pc)
# ... and run where there is no OpenCL platform: the default backend computes on the CPU.
set(ENV{OCL_ICD_VENDORS} ${NO_OPENCL})
run("the pkg-config consumer without OpenCL" ${OUT}/gvd_example_pc)

# docs/CPP.md shows exactly this example.
file(READ ${SRC}/consumer/main.cpp example)
file(READ ${DOC} doc)
string(FIND "${doc}" "```cpp\n${example}```" at)
if(at EQUAL -1)
  message(FATAL_ERROR "docs/CPP.md does not show tests/install/consumer/main.cpp as it is")
endif()
