# End-to-end check of `gvd grid` and `gvd compute --mode grid`: the bundled examples to .npy
# and NRRD, the log naming the backend and the culling, numpy reading the arrays back (when
# /usr/bin/python3 has numpy), the grid's dual graph against the labels it wrote, and the exit
# codes of bad input (usage 2, bad input 3, limit 4).
# Invoked by CTest with -DGVD=<gvd binary> -DDATA=<tests/data> -DOUT=<output dir>.

function(run_rc expected)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL expected)
    message(FATAL_ERROR "expected exit ${expected}, got ${rc}: ${ARGN}\n${out}\n${err}")
  endif()
  set(LAST_ERR "${err}" PARENT_SCOPE)
endfunction()

set(prefix ${OUT}/cli_grid)
run_rc(0 ${GVD} grid ${DATA}/scenes/gears2d.json --resolution 200 -o ${prefix}_gears.npy
       --labels ${prefix}_gears_labels.npy)
if(NOT LAST_ERR MATCHES "backend (cpu|opencl)" OR NOT LAST_ERR MATCHES "site-cell pairs evaluated")
  message(FATAL_ERROR "the log does not say which backend ran and what was culled:\n${LAST_ERR}")
endif()
run_rc(0 ${GVD} grid ${DATA}/scenes/balls_on_plate.json --resolution 40 -o ${prefix}_balls.nrrd
       --labels ${prefix}_balls_labels.nhdr --float64 --metric linf -q)
foreach(f ${prefix}_gears.npy ${prefix}_gears_labels.npy ${prefix}_balls.nrrd
          ${prefix}_balls_labels.nhdr ${prefix}_balls_labels.raw)
  if(NOT EXISTS ${f})
    message(FATAL_ERROR "missing output ${f}")
  endif()
endforeach()
file(STRINGS ${prefix}_balls.nrrd header LIMIT_COUNT 12)
if(NOT header MATCHES "type: double" OR NOT header MATCHES "space origin")
  message(FATAL_ERROR "unexpected NRRD header: ${header}")
endif()
if(header MATCHES "space units")
  message(FATAL_ERROR "a scene without units gave a NRRD with units: ${header}")
endif()
# --units (over the scene's own): the NRRD header says them, one per axis.
run_rc(0 ${GVD} grid ${DATA}/scenes/gears2d.json --resolution 20 -o ${prefix}_units.nrrd
       --units mm -q)
file(STRINGS ${prefix}_units.nrrd header LIMIT_COUNT 14)
if(NOT header MATCHES "space units: \"mm\" \"mm\"")
  message(FATAL_ERROR "--units mm is not the NRRD's space units: ${header}")
endif()
# An unknown --units is a bad flag value (exit 2) naming the flag, as in compute.
run_rc(2 ${GVD} grid ${DATA}/scenes/gears2d.json --resolution 20 -o ${prefix}_x.nrrd
       --units parsec -q)
if(NOT LAST_ERR MATCHES "--units must name a length unit" OR NOT LAST_ERR MATCHES "parsec")
  message(FATAL_ERROR "an unknown --units should be named:\n${LAST_ERR}")
endif()

execute_process(COMMAND /usr/bin/python3 -c "import numpy" RESULT_VARIABLE no_numpy
                OUTPUT_QUIET ERROR_QUIET)
if(no_numpy EQUAL 0)
  # The gears: three closed gear outlines, so some cells are inside (negative) and every
  # label is one of the three objects.
  run_rc(0 /usr/bin/python3 -c "
import numpy as np
d = np.load('${prefix}_gears.npy'); l = np.load('${prefix}_gears_labels.npy')
assert d.dtype == np.float32 and l.dtype == np.int32 and d.shape == l.shape, (d.dtype, l.dtype)
assert d.shape[1] == 200, d.shape
assert set(np.unique(l)) == {0, 1, 2}, np.unique(l)
assert (d < 0).any() and (d > 0).any()
")
  # The grid's labels as a labelled volume in (every pixel an object's, so no background):
  # the dual graph's pairs are the labels whose pixels share an edge (numpy, independently).
  run_rc(0 ${GVD} compute --volume ${prefix}_gears_labels.npy --background none
         --spacing 0.02,0.02 --graph ${prefix}_volume_graph.json -q)
  run_rc(0 /usr/bin/python3 -c "
import json, numpy as np
l = np.load('${prefix}_gears_labels.npy')
want = set()
for a, b in ((l[:, 1:], l[:, :-1]), (l[1:, :], l[:-1, :])):
    m = a != b
    want |= {('label_%d' % min(x, y), 'label_%d' % max(x, y)) for x, y in zip(a[m], b[m])}
g = json.load(open('${prefix}_volume_graph.json'))
got = {(e['label_a'], e['label_b']) for e in g['edges']}
assert got == want, (got, want)
")
endif()
# compute --mode grid: the dual graph of the labels it writes (pairs = labels whose pixels
# share an edge, numpy, independently; areas = shared edges times the pixel size), the gaps
# and clearances measured (positive, clearance <= half the gap + a pixel).
run_rc(0 ${GVD} compute ${DATA}/scenes/gears2d.json --mode grid --resolution 200
       --graph ${prefix}_mode_graph.json --labels ${prefix}_mode_labels.npy)
if(NOT LAST_ERR MATCHES "neighbour pairs" OR NOT LAST_ERR MATCHES "backend (cpu|opencl)|on (cpu|opencl)")
  message(FATAL_ERROR "compute --mode grid does not report its graph and backend:\n${LAST_ERR}")
endif()
if(no_numpy EQUAL 0)
  run_rc(0 /usr/bin/python3 -c "
import json, numpy as np
l = np.load('${prefix}_mode_labels.npy')
want = {}
for a, b in ((l[:, 1:], l[:, :-1]), (l[1:, :], l[:-1, :])):
    m = (a != b) & (a >= 0) & (b >= 0)
    for x, y in zip(a[m], b[m]):
        k = (int(min(x, y)), int(max(x, y)))
        want[k] = want.get(k, 0) + 1
g = json.load(open('${prefix}_mode_graph.json'))
got = {(e['a'], e['b']): e for e in g['edges']}
assert set(got) == set(want), (set(got), set(want))
h = min(a / want[k] for k, a in ((k, got[k]['area']) for k in got))
for k, e in got.items():
    assert abs(e['area'] - want[k] * h) < 1e-9 * e['area'], (k, e['area'], want[k] * h)
    assert e['gap'] > 0 and not e['touching'] and 0 < e['min_clearance'] <= e['gap'] / 2 + 1e-12, e
")
endif()
run_rc(2 ${GVD} compute ${DATA}/scenes/gears2d.json --mode grid --graph ${prefix}_x.json)
run_rc(2 ${GVD} compute ${DATA}/scenes/gears2d.json --mode grid --resolution 50 -o ${prefix}_x.glb)
run_rc(2 ${GVD} compute ${DATA}/scenes/gears2d.json --mode grid --resolution 50
       --graph ${prefix}_x.json --refine paper)
run_rc(2 ${GVD} compute ${DATA}/scenes/gears2d.json --metric l1 --graph ${prefix}_x.json)
run_rc(2 ${GVD} compute ${DATA}/scenes/gears2d.json --mode voxels --graph ${prefix}_x.json)

run_rc(2 ${GVD} compute --volume ${prefix}_gears_labels.npy --spacing 1,1,1 -q)
if(NOT LAST_ERR MATCHES "--spacing needs 2 numbers for this 2D volume, got 3")
  message(FATAL_ERROR "a wrong --spacing count is not named:\n${LAST_ERR}")
endif()
run_rc(2 ${GVD} compute --volume ${prefix}_gears_labels.npy --spacing 1,0 -q)
if(NOT LAST_ERR MATCHES "--spacing must be positive numbers")
  message(FATAL_ERROR "a zero --spacing is not named:\n${LAST_ERR}")
endif()
run_rc(2 ${GVD} compute --volume ${prefix}_gears_labels.npy --spacing 1,1 --background -2 -q)
if(NOT LAST_ERR MATCHES "--background is a label")
  message(FATAL_ERROR "a bad --background is not named:\n${LAST_ERR}")
endif()
run_rc(3 ${GVD} compute --volume ${DATA}/scenes/gears2d.json -q)
# A .npy that is no label volume: invalid input (3) naming the field, as a bad scene is.
run_rc(3 ${GVD} compute --volume ${prefix}_gears.npy --spacing 1,1 -q)
if(NOT LAST_ERR MATCHES "invalid_scene" OR NOT LAST_ERR MATCHES "dtype <f4")
  message(FATAL_ERROR "a float volume is not invalid input naming its dtype:\n${LAST_ERR}")
endif()

run_rc(2 ${GVD} grid ${DATA}/scenes/gears2d.json --resolution 0 -o ${prefix}_x.npy)
run_rc(2 ${GVD} grid ${DATA}/scenes/gears2d.json -o ${prefix}_x.npy)
run_rc(2 ${GVD} grid ${DATA}/scenes/gears2d.json --resolution 10 -o ${prefix}_x.vtk)
run_rc(2 ${GVD} grid ${DATA}/scenes/gears2d.json --resolution 10 -o ${prefix}_x.npy --metric l3)
if(NOT LAST_ERR MATCHES "l3" OR NOT LAST_ERR MATCHES "linf")
  message(FATAL_ERROR "a bad --metric should be named with the metrics:\n${LAST_ERR}")
endif()
run_rc(3 ${GVD} grid ${DATA}/scenes/gears2d.json --resolution 10 -o ${prefix}_x.npy
       --domain 0,0,1,1)
run_rc(4 ${GVD} grid ${DATA}/scenes/gears2d.json --resolution 5000 -o ${prefix}_x.npy
       --max-cells 1000000)
if(NOT LAST_ERR MATCHES "cell limit")
  message(FATAL_ERROR "the limit error does not say which limit:\n${LAST_ERR}")
endif()
file(WRITE ${prefix}_empty.json "{\"dimension\": 2, \"objects\": []}")
run_rc(3 ${GVD} grid ${prefix}_empty.json --resolution 10 -o ${prefix}_x.npy)

# From a saved adaptive result: the same grid, byte for byte, as CuRV on the scene over the
# same box (the result's domain is the box given to compute: already a square).
run_rc(0 ${GVD} compute ${DATA}/scenes/gears2d.json --domain -2,-3,4,3 --save ${prefix}_gears.gvd
       -q)
run_rc(0 ${GVD} grid ${prefix}_gears.gvd --resolution 150 -o ${prefix}_from_result.npy
       --labels ${prefix}_from_result_labels.npy)
if(NOT LAST_ERR MATCHES "from the adaptive result" OR NOT LAST_ERR MATCHES "bounded")
  message(FATAL_ERROR "the log does not say the grid was sampled from the result:\n${LAST_ERR}")
endif()
run_rc(0 ${GVD} grid ${DATA}/scenes/gears2d.json --domain -2,-3,4,3 --resolution 150
       -o ${prefix}_from_scene.npy --labels ${prefix}_from_scene_labels.npy -q)
foreach(kind "" "_labels")
  execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${prefix}_from_result${kind}.npy
                          ${prefix}_from_scene${kind}.npy RESULT_VARIABLE differ)
  if(differ)
    message(FATAL_ERROR "gvd grid RESULT and gvd grid SCENE differ (${kind})")
  endif()
endforeach()
# Bad input on a result: a 3D box for a 2D result, scene-only flags (usage, 2), too many
# cells (4), a truncated result file (3).
run_rc(2 ${GVD} grid ${prefix}_gears.gvd --resolution 10 -o ${prefix}_x.npy --domain 0,0,0,1,1,1)
run_rc(2 ${GVD} grid ${prefix}_gears.gvd --resolution 10 -o ${prefix}_x.npy --range-cells 4)
if(NOT LAST_ERR MATCHES "--range-cells applies to scenes")
  message(FATAL_ERROR "a scene-only flag on a result is not named:\n${LAST_ERR}")
endif()
# gvd grid reads its flags through the parameter table (core/pipeline/parameters.h): its
# ranges and messages, naming the flag (usage, 2).
foreach(bad "--resolution;full;--resolution must be an integer"
            "--resolution;2000000;--resolution must be between 1 and 1048576"
            "--domain;4,3,-2,-3;--domain: the lower corner must be below the upper corner"
            "--threads;-1;--threads must be between 0 and"
            "--max-cells;lots;--max-cells must be a non-negative integer")
  list(GET bad 0 flag)
  list(GET bad 1 value)
  list(GET bad 2 says)
  foreach(input ${DATA}/scenes/gears2d.json ${prefix}_gears.gvd)
    if(NOT flag STREQUAL "--resolution")
      set(resolution --resolution 10)
    else()
      set(resolution)
    endif()
    run_rc(2 ${GVD} grid ${input} ${resolution} ${flag} ${value} -o ${prefix}_x.npy -q)
    if(NOT LAST_ERR MATCHES "${says}")
      message(FATAL_ERROR "gvd grid ${flag} ${value} should say \"${says}\":\n${LAST_ERR}")
    endif()
  endforeach()
endforeach()
# --help: the grid options are the table's, with the grid's own text where it differs (its
# box is not made a cube), and the volume's flags follow --volume.
execute_process(COMMAND ${GVD} --help OUTPUT_VARIABLE help RESULT_VARIABLE rc)
string(FIND "${help}" "grid options (gvd grid" grid_at)
string(FIND "${help}" "query options:" query_at)
if(NOT rc EQUAL 0 OR grid_at LESS 0 OR query_at LESS grid_at)
  message(FATAL_ERROR "gvd --help has no grid options section:\n${help}")
endif()
math(EXPR grid_length "${query_at} - ${grid_at}")
string(SUBSTRING "${help}" ${grid_at} ${grid_length} grid_help)
string(REGEX REPLACE "[ \n]+" " " grid_help "${grid_help}")
foreach(line "--resolution N cells along the longest side"
             "--metric l2|l1|linf" "--float64 distances as float64" "--unsigned no signs"
             "--range-cells N" "--max-cells N"
             "--domain x0,y0[,z0],x1,y1[,z1] domain box; it must hold every vertex"
             "--threads N threads of the CPU twin" "--backend auto|opencl|cpu where the per-range"
             "--units U the length unit" "\"space units\"")
  string(FIND "${grid_help}" "${line}" at)
  if(at LESS 0)
    message(FATAL_ERROR "gvd --help's grid options lack \"${line}\":\n${grid_help}")
  endif()
endforeach()
string(FIND "${grid_help}" "made a cube" at)
if(NOT at LESS 0)
  message(FATAL_ERROR "gvd --help's grid options describe the octree's box:\n${grid_help}")
endif()
string(FIND "${help}" "--volume LABELS.npy" volume_at)
string(FIND "${help}" "--spacing X,Y[,Z]" spacing_at)
string(FIND "${help}" "--background N|none" background_at)
string(FIND "${help}" "--max-depth N" depth_at)
if(volume_at LESS 0 OR spacing_at LESS volume_at OR background_at LESS spacing_at
   OR depth_at LESS background_at)
  message(FATAL_ERROR "gvd --help: --spacing and --background should follow --volume:\n${help}")
endif()
run_rc(4 ${GVD} grid ${prefix}_gears.gvd --resolution 100000 -o ${prefix}_x.npy)
execute_process(COMMAND /usr/bin/python3 -c
                "open('${prefix}_cut.gvd','wb').write(open('${prefix}_gears.gvd','rb').read()[:200])")
if(NOT EXISTS ${prefix}_cut.gvd)
  message(FATAL_ERROR "could not write the truncated result")
endif()
run_rc(3 ${GVD} grid ${prefix}_cut.gvd --resolution 10 -o ${prefix}_x.npy)
if(NOT LAST_ERR MATCHES "checksum|past the end|truncated")
  message(FATAL_ERROR "the truncated result is not reported as such:\n${LAST_ERR}")
endif()
