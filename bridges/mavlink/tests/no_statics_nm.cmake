# Fails when the bridge library defines MAVLink's channel state (m_mavlink_status / m_mavlink_buffer,
# the static arrays behind mavlink_parse_char and the *_chan helpers) or any other writable static:
# the bridge keeps all its state in the caller's ub_mavbridge_t (ub_config.h's rule: no hidden statics).
#   cmake -DNM=<nm> -DLIB=<libuavbus_mavbridge.a> -P no_statics_nm.cmake
cmake_policy(SET CMP0057 NEW) # if(... IN_LIST ...)
execute_process(COMMAND ${NM} ${LIB} OUTPUT_VARIABLE out RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "${NM} ${LIB} failed (${rc})")
endif()
string(REPLACE "\n" ";" lines "${out}")

# AddressSanitizer's own data. Each instrumented object file has one table of descriptors of its globals
# (struct __asan_global), which its constructor hands to __asan_register_globals. gcc names it with a local
# label (.LASAN0), which nm does not list; clang gives it a local symbol in .data, `__unnamed_<n>` (LLVM's
# name for a nameless internal global). It is the sanitizer's, not the bridge's: one such symbol is skipped,
# in an object that registers globals with ASan and nowhere else. The globals it describes are still listed
# under their own names, so a writable static of the bridge fails the check under either compiler.
set(member "?")
set(asan_members "")
foreach(line ${lines})
  if(line MATCHES "^(.+):$")
    set(member "${CMAKE_MATCH_1}")
  elseif(line MATCHES " U __asan_register_globals$")
    list(APPEND asan_members "${member}")
  endif()
endforeach()

set(member "?")
set(asan_table_seen FALSE)
set(offenders "")
foreach(line ${lines})
  if(line MATCHES "^(.+):$")
    set(member "${CMAKE_MATCH_1}")
    set(asan_table_seen FALSE)
  elseif(line MATCHES " [bBdD] (.+)$")
    set(symbol "${CMAKE_MATCH_1}")  # kept: every MATCHES below resets CMAKE_MATCH_*
    # Writable data in the library. The generated directory storage (mav_directories.c: one struct per
    # message, the status) is the application's data, like flightsw_data.c; gcov's counters (__gcov*) are
    # the coverage build's; clang's ASan descriptor table (above) is the sanitizer's; everything else is a
    # finding.
    if(member MATCHES "mav_directories" OR symbol MATCHES "^__gcov")
      continue()
    endif()
    if(line MATCHES " d __unnamed_[0-9]+$" AND NOT asan_table_seen AND member IN_LIST asan_members)
      set(asan_table_seen TRUE)
      continue()
    endif()
    list(APPEND offenders "${member}: ${symbol}")
  endif()
endforeach()
if(offenders)
  string(REPLACE ";" "\n  " listing "${offenders}")
  message(FATAL_ERROR "writable static data in the MAVLink bridge library:\n  ${listing}")
endif()
message(STATUS "no writable statics in ${LIB} outside the directory storage")
