# Frame-security test extras (included by runtime_c/CMakeLists.txt after the test_*.c targets exist):
#  - tests/vectors/signed_frames.json -> a C header for test_sec_vectors (regenerated when the JSON changes);
#  - the router tests' support for test_node_sec, test_tcp_sec, test_secfile and test_sec_noalloc;
#  - the fail-closed build: the whole runtime compiled WITHOUT libsodium (UAVBUS_SECURITY=OFF's code),
#    linked into test_sec_failclosed, which checks that nothing flagged is accepted and nothing signed.

set(UB_SIGNED_VECTORS_JSON ${CMAKE_SOURCE_DIR}/tests/vectors/signed_frames.json)
set(UB_SEC_GEN_DIR ${CMAKE_CURRENT_BINARY_DIR}/generated)
set(UB_SIGNED_VECTORS_H ${UB_SEC_GEN_DIR}/ub_signed_vectors.h)
add_custom_command(
  OUTPUT ${UB_SIGNED_VECTORS_H}
  COMMAND ${CMAKE_COMMAND} -DIN=${UB_SIGNED_VECTORS_JSON} -DOUT=${UB_SIGNED_VECTORS_H}
          -P ${CMAKE_CURRENT_SOURCE_DIR}/tools/signed_vectors_to_c.cmake
  DEPENDS ${UB_SIGNED_VECTORS_JSON} ${CMAKE_CURRENT_SOURCE_DIR}/tools/signed_vectors_to_c.cmake
          ${CMAKE_CURRENT_SOURCE_DIR}/tools/vectors_common.cmake
  COMMENT "Generating ub_signed_vectors.h from tests/vectors/signed_frames.json"
  VERBATIM)
if(TARGET test_sec_vectors)
  target_sources(test_sec_vectors PRIVATE ${UB_SIGNED_VECTORS_H})
  target_include_directories(test_sec_vectors PRIVATE ${UB_SEC_GEN_DIR})
endif()

foreach(t test_node_sec test_lockout test_tcp_sec test_secfile test_sec_noalloc test_origin test_origin_vectors
          test_node_sec_setup)
  if(TARGET ${t})
    target_link_libraries(${t} PRIVATE ub_test_support)
    target_include_directories(${t} PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/tests ${CMAKE_CURRENT_SOURCE_DIR}/src)
    set_tests_properties(${t} PROPERTIES TIMEOUT 60)
  endif()
endforeach()

# test_sec_noalloc replaces the allocator to count libsodium's calls too; ASan owns the allocator.
if(UAVBUS_SANITIZE AND TARGET test_sec_noalloc)
  set_tests_properties(test_sec_noalloc PROPERTIES DISABLED TRUE)
endif()

add_library(ub_nosec STATIC ${UB_SOURCES})
target_include_directories(ub_nosec PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src)
target_compile_definitions(ub_nosec PUBLIC _POSIX_C_SOURCE=200809L)
add_executable(test_sec_failclosed ${CMAKE_CURRENT_SOURCE_DIR}/tests/nosec/test_sec_failclosed.c
                                   ${CMAKE_CURRENT_SOURCE_DIR}/tests/support/ub_test_world.c)
target_include_directories(test_sec_failclosed PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/tests ${UB_SEC_GEN_DIR})
target_sources(test_sec_failclosed PRIVATE ${UB_SIGNED_VECTORS_H})
target_link_libraries(test_sec_failclosed PRIVATE ub_nosec PkgConfig::CMOCKA)
add_test(NAME test_sec_failclosed COMMAND test_sec_failclosed WORKING_DIRECTORY ${CMAKE_SOURCE_DIR})
set_tests_properties(test_sec_failclosed PROPERTIES TIMEOUT 60)
