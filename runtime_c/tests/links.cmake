# Link-layer tests of the links issue (test_log, test_ports): they reuse the router tests' support
# (hand-written catalogue, worlds, the two-node pair). test_impair needs none.
foreach(t test_log test_log_damage test_ports test_ports_refusals test_driver_pipe test_accounting test_contracts test_prio
        test_batchlink)
  if(TARGET ${t})
    target_link_libraries(${t} PRIVATE ub_test_support)
    target_include_directories(${t} PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/tests)
    set_tests_properties(${t} PROPERTIES TIMEOUT 60)
  endif()
endforeach()
