# Coverage test extras (issue #29 item 6): tests of the drivers' private helpers include them by layer path.
if(TARGET test_drv_helpers)
  target_include_directories(test_drv_helpers PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src)
  target_compile_definitions(test_drv_helpers PRIVATE _XOPEN_SOURCE=700) # posix_openpt, grantpt, ptsname
endif()
