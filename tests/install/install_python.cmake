# The installed Python module (docs/PYTHON.md): `cmake --install` of this build into a fresh
# prefix, then Debian's python3 with PYTHONPATH = <prefix>/<GVD_PYTHON_INSTALL_DIR> only (and
# no user site): `import gvd` must come from the installed tree, not the build tree, and the
# examples of docs/PYTHON.md run against it. Nothing is rebuilt.
# Invoked with -DBUILD=<build dir> -DPYTHON=<python3> -DSITE=<GVD_PYTHON_INSTALL_DIR>
# -DDOC=<docs/PYTHON.md> -DRUNNER=<tests/python/run_doc_examples.py> -DOUT=<scratch dir>.

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
set(package ${prefix}/${SITE}/gvd)
foreach(f __init__.py __init__.pyi py.typed)
  if(NOT EXISTS ${package}/${f})
    message(FATAL_ERROR "cmake --install did not install ${SITE}/gvd/${f}")
  endif()
endforeach()
file(GLOB extension ${package}/_gvd*.so)
if(NOT extension)
  message(FATAL_ERROR "cmake --install did not install the extension ${SITE}/gvd/_gvd*.so")
endif()

set(ENV{PYTHONPATH} ${prefix}/${SITE})
set(ENV{PYTHONNOUSERSITE} 1)
set(ENV{PYTHONDONTWRITEBYTECODE} 1)
run("import gvd from the installed tree" ${PYTHON} -c
    "import gvd, numpy as np, os, sys\n\
where = os.path.realpath(gvd.__file__)\n\
assert where.startswith(os.path.realpath(sys.argv[1])), where\n\
s = gvd.Scene(2)\n\
s.add('low', np.array([[0.0, 0.0], [1.0, 0.0]]), np.array([[0, 1]]))\n\
s.add('high', np.array([[0.0, 1.0], [1.0, 1.0]]), np.array([[0, 1]]))\n\
r = gvd.compute(s, backend='cpu')\n\
assert len(r.graph) == 1 and abs(r.graph[0]['gap'] - 1.0) < 1e-12, r.graph\n\
print('gvd', gvd.__version__, 'from', where)" ${prefix})
message(STATUS "${out}")
run("the examples of docs/PYTHON.md" ${PYTHON} ${RUNNER} ${DOC} ${OUT}/examples)
message(STATUS "${out}")
