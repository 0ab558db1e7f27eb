# Publication on update (ub_pubsub_set_on_update): the test uses the shared router test support.
if(TARGET test_pubsub_on_update)
  target_link_libraries(test_pubsub_on_update PRIVATE ub_test_support)
  target_include_directories(test_pubsub_on_update PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/tests ${CMAKE_CURRENT_SOURCE_DIR}/src)
endif()
