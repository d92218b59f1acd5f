# End-to-end check of the `gvd` CLI: compute the bundled examples with every output, read the
# saved result back with `gvd info`, validate the GLB, and check the exit code of bad input.
# Invoked by CTest with -DGVD=<gvd binary> -DDATA=<tests/data> -DOUT=<output dir>.

function(run_ok)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "command failed (${rc}): ${ARGN}\n${out}\n${err}")
  endif()
  set(LAST_OUT "${out}" PARENT_SCOPE)
  set(LAST_ERR "${err}" PARENT_SCOPE)
endfunction()

foreach(scene gears2d balls_on_plate)
  set(prefix ${OUT}/cli_${scene})
  run_ok(${GVD} compute ${DATA}/scenes/${scene}.json -o ${prefix}.glb --graph ${prefix}_graph.json
         --json ${prefix}_gvd.json --save ${prefix}.gvd)
  foreach(f ${prefix}.glb ${prefix}_graph.json ${prefix}_gvd.json ${prefix}.gvd)
    if(NOT EXISTS ${f})
      message(FATAL_ERROR "missing output ${f}")
    endif()
  endforeach()
  if(NOT LAST_ERR MATCHES "backend (cpu|opencl)")
    message(FATAL_ERROR "the log does not say which backend ran:\n${LAST_ERR}")
  endif()
  run_ok(${GVD} info ${prefix}.gvd --json)
  string(JSON depth GET "${LAST_OUT}" depth)
  string(JSON leaves GET "${LAST_OUT}" leaves)
  string(JSON bpl GET "${LAST_OUT}" bytes_per_leaf)
  if(depth LESS 1 OR leaves LESS 2 OR bpl LESS_EQUAL 0)
    message(FATAL_ERROR "gvd info reports implausible figures: ${LAST_OUT}")
  endif()
  # The dual graph must name every object pair that touches in the example.
  file(READ ${prefix}_graph.json graph)
  string(JSON nedges LENGTH "${graph}" edges)
  if(nedges LESS 2)
    message(FATAL_ERROR "dual graph of ${scene} has ${nedges} edges")
  endif()
  find_program(NODE node)
  if(NODE)
    run_ok(${NODE} ${DATA}/../js/validate_glb.mjs ${prefix}.glb)
  endif()
  # Every output again from the saved result, without recomputing: the same bytes.
  run_ok(${GVD} export ${prefix}.gvd -o ${prefix}_export.glb --graph ${prefix}_export_graph.json
         --json ${prefix}_export_gvd.json)
  foreach(pair "${prefix}.glb;${prefix}_export.glb" "${prefix}_graph.json;${prefix}_export_graph.json"
          "${prefix}_gvd.json;${prefix}_export_gvd.json")
    list(GET pair 0 computed)
    list(GET pair 1 exported)
    file(SHA256 ${computed} want)
    file(SHA256 ${exported} got)
    if(NOT want STREQUAL got)
      message(FATAL_ERROR "gvd export wrote ${exported} unlike compute's ${computed}")
    endif()
  endforeach()
  # compute on a saved result says what it is and what to run, naming the file.
  execute_process(COMMAND ${GVD} compute ${prefix}.gvd -o ${prefix}_again.glb
                  RESULT_VARIABLE rc OUTPUT_QUIET ERROR_VARIABLE err)
  if(NOT rc EQUAL 2 OR NOT err MATCHES "cli_${scene}.gvd\" is a saved result" OR
     NOT err MATCHES "gvd export")
    message(FATAL_ERROR "compute on a result should point to export (${rc}): ${err}")
  endif()
endforeach()
# export of a file that is not a result names it (exit 3); without an output, a usage error.
execute_process(COMMAND ${GVD} export ${DATA}/scenes/gears2d.json -o ${OUT}/x.glb
                RESULT_VARIABLE rc OUTPUT_QUIET ERROR_VARIABLE err)
if(NOT rc EQUAL 3 OR NOT err MATCHES "gears2d.json\" is not a saved result")
  message(FATAL_ERROR "export of a scene should say it is not a result (${rc}): ${err}")
endif()
execute_process(COMMAND ${GVD} export ${OUT}/cli_gears2d.gvd RESULT_VARIABLE rc OUTPUT_QUIET
                ERROR_QUIET)
if(NOT rc EQUAL 2)
  message(FATAL_ERROR "export without an output should exit with 2, got ${rc}")
endif()

# Bad input: a clear message and exit code 3, not a crash.
execute_process(COMMAND ${GVD} compute ${DATA}/malformed/json_duplicate_label.json
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 3)
  message(FATAL_ERROR "bad scene should exit with 3, got ${rc}: ${err}")
endif()
# Usage errors exit with 2.
execute_process(COMMAND ${GVD} compute RESULT_VARIABLE rc OUTPUT_QUIET ERROR_QUIET)
if(NOT rc EQUAL 2)
  message(FATAL_ERROR "usage error should exit with 2, got ${rc}")
endif()
