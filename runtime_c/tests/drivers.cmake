# Socket and serial driver tests (test_udp, test_tcp, test_serial, test_legacy_link, test_tcp_edges,
# test_serial_edges): they reuse the router tests' support (hand-written catalogue, the two-node pair) and
# replace the pair's memlink with a real transport (header-only: support/ub_test_pty.h,
# support/ub_test_tcp_pair.h, support/ub_test_foreign.h).
foreach(t test_udp test_tcp test_serial test_legacy_link test_tcp_edges test_serial_edges)
  if(TARGET ${t})
    target_link_libraries(${t} PRIVATE ub_test_support)
    target_include_directories(${t} PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/tests)
    set_tests_properties(${t} PROPERTIES TIMEOUT 60)
  endif()
endforeach()
