# `gvd compute` with no OpenCL platform (CTest points OCL_ICD_VENDORS at an empty folder):
# the default backend (auto) computes on the CPU twins with a log line saying why, and
# `gvd info` reports it; an explicit --backend opencl is an error (exit 3), never a silent
# fallback. Invoked with -DGVD=<gvd binary> -DDATA=<tests/data> -DOUT=<output dir>.

set(scene ${DATA}/scenes/gears2d.json)
execute_process(COMMAND ${GVD} compute ${scene} --save ${OUT}/no_opencl.gvd
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "gvd compute without OpenCL failed (${rc}):\n${err}")
endif()
if(NOT err MATCHES "backend cpu: no OpenCL platform")
  message(FATAL_ERROR "the log does not say that the CPU runs because OpenCL is missing:\n${err}")
endif()
execute_process(COMMAND ${GVD} info ${OUT}/no_opencl.gvd RESULT_VARIABLE rc OUTPUT_VARIABLE out)
if(NOT rc EQUAL 0 OR NOT out MATCHES "backend cpu \\(no OpenCL platform")
  message(FATAL_ERROR "gvd info does not report the CPU fallback (${rc}):\n${out}")
endif()

execute_process(COMMAND ${GVD} compute ${scene} --backend opencl
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 3)
  message(FATAL_ERROR "--backend opencl without a platform should exit with 3, got ${rc}:\n${err}")
endif()
if(NOT err MATCHES "backend opencl requested, but OpenCL unavailable: no OpenCL platform")
  message(FATAL_ERROR "unclear error for --backend opencl without a platform:\n${err}")
endif()

execute_process(COMMAND ${GVD} compute ${scene} --backend cpu -q RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "--backend cpu failed (${rc})")
endif()
