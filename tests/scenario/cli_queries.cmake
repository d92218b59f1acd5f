# End-to-end check of the query commands of `gvd` (nearest, neighbors, path, explode, tight) on a
# saved result and on a scene computed on the fly: JSON shape, exit codes, the exploded GLB.
# Invoked by CTest with -DGVD=<gvd binary> -DDATA=<tests/data> -DOUT=<output dir>.

function(run_expect expected)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL expected)
    message(FATAL_ERROR "expected exit ${expected}, got ${rc}: ${ARGN}\n${out}\n${err}")
  endif()
  set(LAST_OUT "${out}" PARENT_SCOPE)
  set(LAST_ERR "${err}" PARENT_SCOPE)
endfunction()

set(result ${OUT}/queries_balls.gvd)
run_expect(0 ${GVD} compute ${DATA}/scenes/balls_on_plate.json --save ${result} -q)

# Neighbours: every ball touches the plate's cell.
run_expect(0 ${GVD} neighbors ${result} --object plate --ring 1)
string(JSON n LENGTH "${LAST_OUT}" neighbors)
if(NOT n EQUAL 4)
  message(FATAL_ERROR "plate should have the 4 balls as 1-ring neighbours: ${LAST_OUT}")
endif()
run_expect(5 ${GVD} neighbors ${result} --object no_such_object)

# Nearest: one JSON line per point, the point echoed; outside the domain -> exit 3.
file(WRITE ${OUT}/queries_points.json "[[0.1,0.2,0.3],[0.5,0.5,-0.05]]")
run_expect(0 ${GVD} nearest ${result} --points ${OUT}/queries_points.json)
string(REGEX MATCHALL "\n" lines "${LAST_OUT}")
list(LENGTH lines nlines)
if(NOT nlines EQUAL 2 OR NOT LAST_OUT MATCHES "\"point\":\\[0.1,0.2,0.3\\]")
  message(FATAL_ERROR "nearest should print one line per point: ${LAST_OUT}")
endif()
run_expect(3 ${GVD} nearest ${result} --point 100,0,0)
# Every point is answered; one outside the domain gets an error entry (and exit 3).
run_expect(3 ${GVD} nearest ${result} --point 0.1,0.2,0.3 --point 100,0,0)
if(NOT LAST_OUT MATCHES "\"point\":\\[0.1,0.2,0.3\\]" OR
   NOT LAST_OUT MATCHES "\"code\":\"outside_domain\"")
  message(FATAL_ERROR "nearest should answer the inner point and flag the outer one: ${LAST_OUT}")
endif()
run_expect(2 ${GVD} nearest ${result} --point 1,2)

# Paths: found above the balls; none from the centre of a ball (exit 7, reason given).
run_expect(0 ${GVD} path ${result} --from 0.5,0.5,0.8 --to 0.2,0.9,0.05 --cost clearance)
string(JSON npoints LENGTH "${LAST_OUT}" points)
if(npoints LESS 3)
  message(FATAL_ERROR "path should run along the GVD: ${LAST_OUT}")
endif()
run_expect(7 ${GVD} path ${result} --from 0,0,0.5 --to 0.2,0.9,0.05)
string(JSON reason GET "${LAST_OUT}" reason)
string(JSON npoints LENGTH "${LAST_OUT}" points)
if(NOT npoints EQUAL 0 OR reason STREQUAL "")
  message(FATAL_ERROR "no-path answer should have no points and a reason: ${LAST_OUT}")
endif()

# Exploded view: JSON vectors and a GLB that passes the Khronos validator.
run_expect(0 ${GVD} explode ${result} --anchor plate -o ${OUT}/queries_exploded.glb -q)
string(JSON nobjects LENGTH "${LAST_OUT}" objects)
if(NOT nobjects EQUAL 5)
  message(FATAL_ERROR "explode should list every object: ${LAST_OUT}")
endif()
find_program(NODE node)
if(NODE)
  run_expect(0 ${NODE} ${DATA}/../js/validate_glb.mjs ${OUT}/queries_exploded.glb)
endif()

# Clearance report: the balls sit 1e-3 / 5e-4 apart; a bound of 1 catches every pair.
run_expect(0 ${GVD} tight ${result} --below 1)
string(JSON npairs LENGTH "${LAST_OUT}" pairs)
if(npairs LESS 4)
  message(FATAL_ERROR "tight --below 1 should report the close pairs: ${LAST_OUT}")
endif()

# Contacts: the balls sit 1e-3 / 5e-4 from the plate; a bound of 1e-2 catches each pair, with
# its exact gap below the bound and at least one site of the interface.
run_expect(0 ${GVD} contacts ${result} --max-gap 1e-2)
string(JSON ncontacts LENGTH "${LAST_OUT}" contacts)
if(ncontacts LESS 4)
  message(FATAL_ERROR "contacts --max-gap 1e-2 should report the balls on the plate: ${LAST_OUT}")
endif()
math(EXPR last "${ncontacts} - 1")
foreach(i RANGE ${last})
  string(JSON gap GET "${LAST_OUT}" contacts ${i} gap)
  string(JSON nsites LENGTH "${LAST_OUT}" contacts ${i} sites)
  if(gap GREATER_EQUAL 1e-2 OR nsites LESS 1)
    message(FATAL_ERROR "contact ${i}: gap ${gap} and ${nsites} sites: ${LAST_OUT}")
  endif()
endforeach()
run_expect(2 ${GVD} contacts ${result} --max-gap -1)

# A scene instead of a result: computed first.
run_expect(0 ${GVD} neighbors ${DATA}/scenes/gears2d.json --object gear_a -q)

# `gvd COMMAND --help` (or -h) prints that command's usage to stdout and exits 0, whatever
# else is given; not "unknown option --help". Each names its own synopsis and option and not
# another command's.
set(own_compute "--max-depth")
set(own_info "--json")
set(own_export "--units")
set(own_nearest "--points")
set(own_neighbors "--ring")
set(own_path "--min-clearance")
set(own_explode "--seconds")
set(own_tight "--below")
set(own_contacts "--max-gap")
set(own_grid "--labels")
set(commands compute info export nearest neighbors path explode tight contacts grid)
foreach(cmd ${commands})
  foreach(flag --help -h)
    run_expect(0 ${GVD} ${cmd} ${flag})
    string(FIND "${LAST_OUT}" "gvd ${cmd} " at)
    string(FIND "${LAST_OUT}" "${own_${cmd}}" own_at)
    if(at LESS 0 OR own_at LESS 0)
      message(FATAL_ERROR "gvd ${cmd} ${flag} lacks its synopsis or ${own_${cmd}}: ${LAST_OUT}")
    endif()
    foreach(other ${commands})
      string(FIND "${LAST_OUT}" "  gvd ${other} " other_at)
      if(NOT other STREQUAL cmd AND other_at GREATER_EQUAL 0)
        message(FATAL_ERROR "gvd ${cmd} ${flag} shows gvd ${other}'s usage: ${LAST_OUT}")
      endif()
    endforeach()
  endforeach()
endforeach()
run_expect(0 ${GVD} neighbours --help)
run_expect(2 ${GVD} frobnicate --help)
run_expect(0 ${GVD} compute ${DATA}/scenes/gears2d.json --help)
