# Units end to end through `gvd` (docs/FORMATS.md, "Units"): a scene's "units" reach the graph
# JSON, the saved result, `gvd info` (text and JSON), the query answers and the summary; a
# scene without units says none; --units sets or overrides them; an unknown unit is refused
# naming the field. Invoked by CTest with -DGVD=<gvd binary> -DDATA=<tests/data> -DOUT=<dir>.

function(run_expect expected)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL expected)
    message(FATAL_ERROR "expected exit ${expected}, got ${rc}: ${ARGN}\n${out}\n${err}")
  endif()
  set(LAST_OUT "${out}" PARENT_SCOPE)
  set(LAST_ERR "${err}" PARENT_SCOPE)
endfunction()

# The "units" member of a JSON text, or NONE when it has none.
function(units_of text var)
  string(JSON u ERROR_VARIABLE missing GET "${text}" units)
  if(missing)
    set(u NONE)
  endif()
  set(${var} "${u}" PARENT_SCOPE)
endfunction()

function(expect_units text expected what)
  units_of("${text}" u)
  if(NOT u STREQUAL expected)
    message(FATAL_ERROR "${what}: expected units ${expected}, got ${u}:\n${text}")
  endif()
endfunction()

set(dir ${OUT}/units)
file(MAKE_DIRECTORY ${dir})
# Two squares 0.25 apart, in millimetres.
file(WRITE ${dir}/mm.json [=[{"dimension": 2, "units": "mm", "objects": [
  {"label": "a", "vertices": [[0,0],[1,0],[1,1],[0,1]], "segments": [[0,1],[1,2],[2,3],[3,0]]},
  {"label": "b", "vertices": [[1.25,0],[2,0],[2,1],[1.25,1]], "segments": [[0,1],[1,2],[2,3],[3,0]]}]}
]=])
file(READ ${dir}/mm.json mm_text)
string(REPLACE "\"units\": \"mm\", " "" plain "${mm_text}")
file(WRITE ${dir}/plain.json "${plain}")

# With units: the summary, the graph, the saved result, info, and every query say them.
run_expect(0 ${GVD} compute ${dir}/mm.json --graph ${dir}/mm_graph.json --json ${dir}/mm_gvd.json
           --save ${dir}/mm.gvd)
if(NOT LAST_ERR MATCHES "units mm" OR NOT LAST_ERR MATCHES "side [0-9.e+-]+ mm"
   OR NOT LAST_ERR MATCHES "are [0-9.e+-]+ mm apart")
  message(FATAL_ERROR "the summary should say the lengths' units:\n${LAST_ERR}")
endif()
file(READ ${dir}/mm_graph.json graph)
expect_units("${graph}" mm "graph JSON")
file(READ ${dir}/mm_gvd.json gvd_json)
expect_units("${gvd_json}" mm "float64 GVD JSON")
run_expect(0 ${GVD} info ${dir}/mm.gvd --json)
expect_units("${LAST_OUT}" mm "info --json of the reloaded result")
run_expect(0 ${GVD} info ${dir}/mm.gvd)
if(NOT LAST_OUT MATCHES "units mm")
  message(FATAL_ERROR "gvd info should say the units:\n${LAST_OUT}")
endif()
run_expect(0 ${GVD} tight ${dir}/mm.gvd --below 1)
expect_units("${LAST_OUT}" mm "tight")
string(JSON npairs LENGTH "${LAST_OUT}" pairs)
if(npairs LESS 1)
  message(FATAL_ERROR "tight --below 1 should report the pair: ${LAST_OUT}")
endif()
run_expect(0 ${GVD} nearest ${dir}/mm.gvd --point 1.1,0.5)
expect_units("${LAST_OUT}" mm "nearest")
run_expect(0 ${GVD} contacts ${dir}/mm.gvd --max-gap 1)
expect_units("${LAST_OUT}" mm "contacts")
run_expect(0 ${GVD} neighbors ${dir}/mm.gvd --object a)
expect_units("${LAST_OUT}" mm "neighbors")

# Without units: nothing is invented.
run_expect(0 ${GVD} compute ${dir}/plain.json --graph ${dir}/plain_graph.json --save
           ${dir}/plain.gvd)
if(LAST_ERR MATCHES ", units " OR LAST_ERR MATCHES " mm")
  message(FATAL_ERROR "a scene without units should get none:\n${LAST_ERR}")
endif()
file(READ ${dir}/plain_graph.json graph)
expect_units("${graph}" NONE "graph JSON without units")
run_expect(0 ${GVD} tight ${dir}/plain.gvd --below 1)
expect_units("${LAST_OUT}" NONE "tight without units")
run_expect(0 ${GVD} info ${dir}/plain.gvd --json)
expect_units("${LAST_OUT}" NONE "info --json without units")

# --units sets them (meshes and unit-less scenes) and overrides a scene's own, saying so.
run_expect(0 ${GVD} compute ${dir}/plain.json --units um --graph ${dir}/um_graph.json -q)
file(READ ${dir}/um_graph.json graph)
expect_units("${graph}" "µm" "--units um on a scene without units")
run_expect(0 ${GVD} compute ${dir}/mm.json --units m --graph ${dir}/m_graph.json)
file(READ ${dir}/m_graph.json graph)
expect_units("${graph}" m "--units m over the scene's mm")
if(NOT LAST_ERR MATCHES "--units m replaces the input's units \"mm\"")
  message(FATAL_ERROR "overriding a scene's units should be said:\n${LAST_ERR}")
endif()
run_expect(0 ${GVD} tight ${dir}/plain.gvd --below 1 --units cm)
expect_units("${LAST_OUT}" cm "--units on a saved result")
run_expect(0 ${GVD} export ${dir}/plain.gvd --units ft --graph ${dir}/ft_graph.json -q)
file(READ ${dir}/ft_graph.json graph)
expect_units("${graph}" ft "export --units")

# Unknown units: the field named, the value quoted, the known units listed; a scene file's are
# invalid input (exit 3), --units' a bad flag value (exit 2, as for every other flag).
string(REPLACE "\"units\": \"mm\"" "\"units\": \"parsec\"" bad "${mm_text}")
file(WRITE ${dir}/parsec.json "${bad}")
run_expect(3 ${GVD} compute ${dir}/parsec.json -q)
if(NOT LAST_ERR MATCHES "\"units\" must name a length unit" OR NOT LAST_ERR MATCHES "parsec"
   OR NOT LAST_ERR MATCHES "mm, cm")
  message(FATAL_ERROR "an unknown unit should be named with its field:\n${LAST_ERR}")
endif()
run_expect(2 ${GVD} compute ${dir}/plain.json --units furlong -q)
if(NOT LAST_ERR MATCHES "--units must name a length unit" OR NOT LAST_ERR MATCHES "furlong")
  message(FATAL_ERROR "an unknown --units should be named:\n${LAST_ERR}")
endif()
