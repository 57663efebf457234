# Regenerates the URDFs from config/ur_dh.json and fails unless they equal config/*.urdf byte for byte.
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})
execute_process(COMMAND ${PYTHON} ${SOURCE_DIR}/tools/gen_ur_urdf.py
                  --table ${SOURCE_DIR}/config/ur_dh.json --out-dir ${WORK_DIR}
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "tools/gen_ur_urdf.py failed (${rc}): ${out}${err}")
endif()
foreach(robot ur10 ur10e)
  execute_process(COMMAND ${CMAKE_COMMAND} -E compare_files ${WORK_DIR}/${robot}.urdf
                    ${SOURCE_DIR}/config/${robot}.urdf RESULT_VARIABLE differ)
  if(NOT differ EQUAL 0)
    message(FATAL_ERROR "config/${robot}.urdf is not what tools/gen_ur_urdf.py generates from "
                        "config/ur_dh.json: run `python3 tools/gen_ur_urdf.py` and commit the result")
  endif()
endforeach()
message(STATUS "config/ur10.urdf and config/ur10e.urdf match config/ur_dh.json")
