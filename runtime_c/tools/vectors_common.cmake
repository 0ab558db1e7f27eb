# Helpers shared by the vector-to-C scripts (frame_vectors_to_c.cmake, signed_vectors_to_c.cmake).

# "a55b..." -> "0xa5,0x5b,..." (empty stays empty; C gets a dummy byte so the array is never empty)
function(hex_to_c hex out)
  string(REGEX REPLACE "([0-9a-fA-F][0-9a-fA-F])" "0x\\1," bytes "${hex}")
  if(bytes STREQUAL "")
    set(bytes "0x00")
  endif()
  set(${out} "${bytes}" PARENT_SCOPE)
endfunction()

# Number of bytes a hex string encodes.
function(hex_len hex out)
  string(LENGTH "${hex}" n)
  math(EXPR n "${n} / 2")
  set(${out} ${n} PARENT_SCOPE)
endfunction()
