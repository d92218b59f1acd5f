# cmake -DSRC=clients/web -DDST=build/web -DEXAMPLES=tests/data/scenes -P copy_web.cmake
# Copies index.html, viewer/ and the few three.js files the viewer imports (whole build/ folder
# content it needs: three.module.js imports ./three.core.js) into DST, only when they changed;
# and the example scenes of the page's "Try an example" buttons into DST/viewer/examples.
set(THREE ${SRC}/node_modules/three)
set(THREE_FILES
  build/three.module.js build/three.core.js
  examples/jsm/controls/OrbitControls.js
  examples/jsm/loaders/GLTFLoader.js
  examples/jsm/lines/LineMaterial.js
  examples/jsm/lines/LineSegments2.js
  examples/jsm/lines/LineSegmentsGeometry.js
  examples/jsm/utils/BufferGeometryUtils.js
  examples/jsm/utils/SkeletonUtils.js
  LICENSE)

file(MAKE_DIRECTORY ${DST}/viewer)
file(COPY_FILE ${SRC}/index.html ${DST}/index.html ONLY_IF_DIFFERENT)
file(GLOB viewer_files RELATIVE ${SRC}/viewer ${SRC}/viewer/*)
foreach(f IN LISTS viewer_files)
  file(COPY_FILE ${SRC}/viewer/${f} ${DST}/viewer/${f} ONLY_IF_DIFFERENT)
endforeach()

set(EXAMPLE_SCENES balls_on_plate.json gears2d.json)
file(MAKE_DIRECTORY ${DST}/viewer/examples)
foreach(f IN LISTS EXAMPLE_SCENES)
  file(COPY_FILE ${EXAMPLES}/${f} ${DST}/viewer/examples/${f} ONLY_IF_DIFFERENT)
endforeach()

if(NOT EXISTS ${THREE}/package.json)
  message(WARNING "three.js is not installed in ${SRC}/node_modules: run docker/install-deps.sh "
                  "(npm ci in clients/web); the viewer will say it cannot load three.js")
  return()
endif()
foreach(f IN LISTS THREE_FILES)
  get_filename_component(dir ${DST}/vendor/three/${f} DIRECTORY)
  file(MAKE_DIRECTORY ${dir})
  file(COPY_FILE ${THREE}/${f} ${DST}/vendor/three/${f} ONLY_IF_DIFFERENT)
endforeach()
