# tests/vectors/inspect.json -> a C header for test_inspect_vectors (regenerated when the JSON changes);
# test_inspect runs on the in-memory test world.
set(UB_INSPECT_VECTORS_JSON ${UAVBUS_SOURCE_DIR}/tests/vectors/inspect.json)
set(UB_INSPECT_GEN_DIR ${CMAKE_CURRENT_BINARY_DIR}/generated)
set(UB_INSPECT_VECTORS_H ${UB_INSPECT_GEN_DIR}/ub_inspect_vectors.h)
add_custom_command(
  OUTPUT ${UB_INSPECT_VECTORS_H}
  COMMAND ${CMAKE_COMMAND} -DIN=${UB_INSPECT_VECTORS_JSON} -DOUT=${UB_INSPECT_VECTORS_H}
          -P ${CMAKE_CURRENT_SOURCE_DIR}/tools/inspect_vectors_to_c.cmake
  DEPENDS ${UB_INSPECT_VECTORS_JSON} ${CMAKE_CURRENT_SOURCE_DIR}/tools/inspect_vectors_to_c.cmake
          ${CMAKE_CURRENT_SOURCE_DIR}/tools/vectors_common.cmake
  COMMENT "Generating ub_inspect_vectors.h from tests/vectors/inspect.json"
  VERBATIM)
if(TARGET test_inspect_vectors)
  target_sources(test_inspect_vectors PRIVATE ${UB_INSPECT_VECTORS_H})
  target_include_directories(test_inspect_vectors PRIVATE ${UB_INSPECT_GEN_DIR})
endif()
if(TARGET test_inspect)
  target_link_libraries(test_inspect PRIVATE ub_test_support)
  target_include_directories(test_inspect PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/tests ${CMAKE_CURRENT_SOURCE_DIR}/src)
endif()
