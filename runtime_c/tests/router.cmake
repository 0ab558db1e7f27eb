# Router/pub-sub test extras (included by runtime_c/CMakeLists.txt after the test_*.c targets exist):
#  - the shared test support (hand-written catalogues, the memlink "world", the authorization world) for the
#    router tests;
#  - test_noalloc counts malloc/calloc/realloc/free through -Wl,--wrap;
#  - ub_noalloc_nm: the static library must not reference any allocator symbol at all.

set(UB_ROUTER_TESTS test_node test_router test_pubsub test_admin test_memlink test_table1 test_faults test_loops test_handover
                    test_layout test_noalloc test_authz test_route test_member test_rxring test_route_due
                    test_memlink_edges test_route_scale test_route_slow)
foreach(t ${UB_ROUTER_TESTS})
  if(TARGET ${t})
    target_link_libraries(${t} PRIVATE ub_test_support)
    target_include_directories(${t} PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/tests ${CMAKE_CURRENT_SOURCE_DIR}/src)
  endif()
endforeach()

if(TARGET test_noalloc)
  target_link_options(test_noalloc PRIVATE -Wl,--wrap=malloc -Wl,--wrap=calloc -Wl,--wrap=realloc -Wl,--wrap=free)
endif()

add_test(NAME ub_noalloc_nm
         COMMAND ${CMAKE_COMMAND} -DNM=${CMAKE_NM} -DLIB=$<TARGET_FILE:ub>
                 -P ${CMAKE_CURRENT_SOURCE_DIR}/tests/support/noalloc_nm.cmake)
set_tests_properties(ub_noalloc_nm PROPERTIES TIMEOUT 60)

# Router cost measurement program (not a test), optimised whatever the build type.
add_executable(ub_router_bench ${CMAKE_CURRENT_SOURCE_DIR}/tests/support/router_bench.c
                               ${CMAKE_CURRENT_SOURCE_DIR}/tests/support/ub_test_world.c
                               ${CMAKE_CURRENT_SOURCE_DIR}/src/core/ub_node.c ${CMAKE_CURRENT_SOURCE_DIR}/src/svc/ub_pubsub.c
                               ${CMAKE_CURRENT_SOURCE_DIR}/src/svc/ub_admin.c ${CMAKE_CURRENT_SOURCE_DIR}/src/core/ub_link.c
                               ${CMAKE_CURRENT_SOURCE_DIR}/src/svc/ub_route.c ${CMAKE_CURRENT_SOURCE_DIR}/src/svc/ub_member.c
                               ${CMAKE_CURRENT_SOURCE_DIR}/src/svc/ub_inspect.c ${CMAKE_CURRENT_SOURCE_DIR}/src/svc/ub_node_std.c
                               ${CMAKE_CURRENT_SOURCE_DIR}/src/core/ub_node_svc.c ${CMAKE_CURRENT_SOURCE_DIR}/src/core/ub_prio.c
                               ${CMAKE_CURRENT_SOURCE_DIR}/src/core/ub_node_sec.c ${CMAKE_CURRENT_SOURCE_DIR}/src/codec/ub_sec.c
                               ${CMAKE_CURRENT_SOURCE_DIR}/src/drivers/ub_memlink.c ${CMAKE_CURRENT_SOURCE_DIR}/src/codec/ub_frame.c
                               ${CMAKE_CURRENT_SOURCE_DIR}/src/codec/ub_crc32c.c ${CMAKE_CURRENT_SOURCE_DIR}/src/codec/ub_catalogue.c
                               ${CMAKE_CURRENT_SOURCE_DIR}/src/codec/ub_error.c ${CMAKE_CURRENT_SOURCE_DIR}/src/config/ub_policy.c
                               ${CMAKE_CURRENT_SOURCE_DIR}/src/codec/ub_json.c ${CMAKE_CURRENT_SOURCE_DIR}/src/codec/ub_compact.c
                               ${CMAKE_CURRENT_SOURCE_DIR}/src/codec/ub_frag.c ${CMAKE_CURRENT_SOURCE_DIR}/src/core/ub_node_wire.c
                               ${CMAKE_CURRENT_SOURCE_DIR}/src/core/ub_timeheap.c)
target_include_directories(ub_router_bench PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/include ${CMAKE_CURRENT_SOURCE_DIR}/src
                                                   ${CMAKE_CURRENT_SOURCE_DIR}/tests)
target_compile_definitions(ub_router_bench PRIVATE _POSIX_C_SOURCE=200809L)
target_compile_options(ub_router_bench PRIVATE -O2)
target_link_libraries(ub_router_bench PRIVATE PkgConfig::CMOCKA)
if(UAVBUS_SECURITY)
  target_compile_definitions(ub_router_bench PRIVATE UB_SECURITY=1)
  target_link_libraries(ub_router_bench PRIVATE PkgConfig::SODIUM)
endif()
ub_measurement_tool(ub_router_bench)
