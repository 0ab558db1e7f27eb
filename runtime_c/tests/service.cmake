# The service contract and the layers (docs/architecture.md, "Layers"):
#  - test_service: an echo service written against the public headers only. Its target gets the test
#    support (the memlink world) but not the private include directory src/: a private include would
#    not compile, so the test proves a service needs nothing else.
#  - ub_layer_check: svc/ reaches the node only through ub_node_svc.h, codec/ stays the wire layer
#    (runtime_c/tools/check_layers.cmake);
#  - ub_layer_check_selftest: the check passes on the tree and fails on planted breaches.
if(TARGET test_service)
  target_link_libraries(test_service PRIVATE ub_test_support)
  target_include_directories(test_service PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/tests)
endif()

add_test(NAME ub_layer_check
         COMMAND ${CMAKE_COMMAND} -DSRC=${CMAKE_CURRENT_SOURCE_DIR}/src -DINC=${CMAKE_CURRENT_SOURCE_DIR}/include
                 -P ${CMAKE_CURRENT_SOURCE_DIR}/tools/check_layers.cmake)
add_test(NAME ub_layer_check_selftest
         COMMAND ${CMAKE_COMMAND} -DSRC=${CMAKE_CURRENT_SOURCE_DIR}/src -DINC=${CMAKE_CURRENT_SOURCE_DIR}/include
                 -DCHECK=${CMAKE_CURRENT_SOURCE_DIR}/tools/check_layers.cmake
                 -DWORK=${CMAKE_CURRENT_BINARY_DIR}/layer_check_selftest
                 -P ${CMAKE_CURRENT_SOURCE_DIR}/tools/check_layers_selftest.cmake)
set_tests_properties(ub_layer_check ub_layer_check_selftest PROPERTIES TIMEOUT 60)
