# Wire test extras (included by runtime_c/CMakeLists.txt after the test_*.c targets exist): the compact-frame
# and fragment vectors are read at run time with the runtime's private JSON reader (src/ub_json.h); the node
# tests use the shared test support (memlink worlds, hand-written catalogues).
if(TARGET test_compact_vectors)
  target_include_directories(test_compact_vectors PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src)
endif()
foreach(t test_compact test_frag test_wire_paths test_wire_edges)
  if(TARGET ${t})
    target_link_libraries(${t} PRIVATE ub_test_support)
    target_include_directories(${t} PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/tests ${CMAKE_CURRENT_SOURCE_DIR}/src)
  endif()
endforeach()
if(TARGET test_legacy_vectors)
  target_include_directories(test_legacy_vectors PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src)
endif()
