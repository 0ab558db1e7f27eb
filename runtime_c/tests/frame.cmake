# Frame codec extras (included by runtime_c/CMakeLists.txt after the test_*.c targets exist):
#  - tests/vectors/frames.json -> a C header for test_frame_vectors, regenerated when the JSON changes;
#  - the measurement programs in tools/ (not tests): ub_frame_bench and ub_far.

set(UB_FRAME_VECTORS_JSON ${UAVBUS_SOURCE_DIR}/tests/vectors/frames.json)
set(UB_FRAME_GEN_DIR ${CMAKE_CURRENT_BINARY_DIR}/generated)
set(UB_FRAME_VECTORS_H ${UB_FRAME_GEN_DIR}/ub_frame_vectors.h)
add_custom_command(
  OUTPUT ${UB_FRAME_VECTORS_H}
  COMMAND ${CMAKE_COMMAND} -DIN=${UB_FRAME_VECTORS_JSON} -DOUT=${UB_FRAME_VECTORS_H}
          -P ${CMAKE_CURRENT_SOURCE_DIR}/tools/frame_vectors_to_c.cmake
  DEPENDS ${UB_FRAME_VECTORS_JSON} ${CMAKE_CURRENT_SOURCE_DIR}/tools/frame_vectors_to_c.cmake
          ${CMAKE_CURRENT_SOURCE_DIR}/tools/vectors_common.cmake
  COMMENT "Generating ub_frame_vectors.h from tests/vectors/frames.json"
  VERBATIM)
if(TARGET test_frame_vectors)
  target_sources(test_frame_vectors PRIVATE ${UB_FRAME_VECTORS_H})
  target_include_directories(test_frame_vectors PRIVATE ${UB_FRAME_GEN_DIR})
endif()

# The tools compile the codec sources themselves at -O2, so their figures describe an
# optimised build whatever CMAKE_BUILD_TYPE the library was configured with.
set(UB_FRAME_CODEC_SOURCES ${CMAKE_CURRENT_SOURCE_DIR}/src/codec/ub_frame.c ${CMAKE_CURRENT_SOURCE_DIR}/src/codec/ub_crc32c.c
                           ${CMAKE_CURRENT_SOURCE_DIR}/src/codec/ub_error.c)
foreach(tool ub_frame_bench ub_far)
  if(NOT EXISTS ${CMAKE_CURRENT_SOURCE_DIR}/tools/${tool}.c)
    continue()
  endif()
  add_executable(${tool} ${CMAKE_CURRENT_SOURCE_DIR}/tools/${tool}.c ${UB_FRAME_CODEC_SOURCES}
                         ${CMAKE_CURRENT_SOURCE_DIR}/src/codec/ub_compact.c ${CMAKE_CURRENT_SOURCE_DIR}/src/codec/ub_catalogue.c)
  target_include_directories(${tool} PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/include ${CMAKE_CURRENT_SOURCE_DIR}/src)
  target_compile_definitions(${tool} PRIVATE _POSIX_C_SOURCE=200809L)
  target_compile_options(${tool} PRIVATE -O2)
  ub_measurement_tool(${tool})
endforeach()
