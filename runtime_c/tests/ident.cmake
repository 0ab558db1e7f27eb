# Identity per entity (ub_ident.h, ub_identfile.h, ub_revoke.h):
#  - test_ident: certificates, records, the store, identity files (the test support's authority);
#  - test_ident_vectors: tests/vectors/identity.json rebuilt in C byte for byte (read at run time with the
#    runtime's own JSON reader, a private codec/ header: hence src/);
#  - test_revoke: the revocation service spreading a record over memlinks to a 2-hop neighbour.
foreach(t test_ident test_ident_vectors test_revoke)
  if(TARGET ${t})
    target_include_directories(${t} PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/tests)
    set_tests_properties(${t} PROPERTIES TIMEOUT 60)
  endif()
endforeach()
if(TARGET test_ident_vectors)
  target_include_directories(test_ident_vectors PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src)
endif()
if(TARGET test_revoke)
  target_link_libraries(test_revoke PRIVATE ub_test_support)
endif()
