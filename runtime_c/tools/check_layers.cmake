# The layering rule of runtime_c/src (docs/architecture.md, "Layers"), checked on the sources so it cannot
# rot again. Run by ctest as ub_layer_check (and its own test, ub_layer_check_selftest):
#   cmake -DSRC=<runtime_c/src> -DINC=<runtime_c/include> [-DSVC_DIR=<dir>] [-DCODEC_DIR=<dir>] -P check_layers.cmake
#
#  - svc/ (the services: publish/subscribe, administration, routing, membership, inspection) reach the
#    node only through its public headers (ub_node.h, ub_node_svc.h, ub_service.h): no include of a
#    core/ (or drivers/, app/) header, and no access to ub_node_t's fields. The fields are recognised
#    by what reaches them: a pointer named *node dereferenced (`node->x`, `rt->node->x`), or a member
#    only ub_node_t has (`->locals`, `.entities[`...). The build makes the struct opaque to svc/ as
#    well (UB_NODE_OPAQUE), so a compiler catches what a pattern could miss.
#  - codec/ (frames, CRC, compact encoding, fragments, security transforms, JSON) is the wire layer:
#    it includes system headers, its own headers and the public headers of the wire layer only, never
#    the node, the services, the drivers or a private header of another layer.
# SVC_DIR / CODEC_DIR default to SRC/svc and SRC/codec; the self-test points them at planted copies.
if(NOT SRC OR NOT INC)
  message(FATAL_ERROR "usage: cmake -DSRC=<runtime_c/src> -DINC=<runtime_c/include> -P check_layers.cmake")
endif()
if(NOT SVC_DIR)
  set(SVC_DIR "${SRC}/svc")
endif()
if(NOT CODEC_DIR)
  set(CODEC_DIR "${SRC}/codec")
endif()

# Public headers of the wire layer: what codec/ may include (and what they include, checked below).
set(wire_headers ub_admin_wire.h ub_catalogue.h ub_compact.h ub_config.h ub_crc32c.h ub_error.h ub_frag.h ub_gps_fields.h ub_ident.h ub_legacy.h ub_nmea.h ub_ubx.h
                 ub_frame.h ub_random.h ub_sec.h ub_wire.h)
# Members only struct ub_node has (the generic names, counters or opt, are every engine's own too).
set(node_members locals entities bindings n_bindings bind_table next_seq rng_state require_signed use_stamp
                 tap_user deliver_user mtu_links last_content services n_services svc_by_code data_svc)
string(REPLACE ";" "|" node_members_re "${node_members}")

set(problems "")
set(checked 0)

# Lines of `file` as a list, with `;` and brackets made harmless for CMake lists (an unbalanced `[` would
# join lines).
function(read_lines file out)
  file(READ "${file}" text)
  string(REPLACE ";" "<semi>" text "${text}")
  string(REPLACE "[" "<lb>" text "${text}")
  string(REPLACE "]" "<rb>" text "${text}")
  string(REPLACE "\n" ";" lines "${text}")
  set(${out} "${lines}" PARENT_SCOPE)
endfunction()

file(GLOB svc_files "${SVC_DIR}/*.c" "${SVC_DIR}/*.h")
foreach(f ${svc_files})
  math(EXPR checked "${checked} + 1")
  read_lines("${f}" lines)
  set(n 0)
  foreach(line IN LISTS lines)
    math(EXPR n "${n} + 1")
    if(line MATCHES "^[ \t]*#[ \t]*include[ \t]*\"(core|drivers|app|config)/")
      list(APPEND problems "${f}:${n}: a service includes a private header of another layer (${CMAKE_MATCH_1}/): use ub/ub_node_svc.h")
    endif()
    # Comments are not code: a banner may say "node->" in prose.
    string(REGEX REPLACE "/\\*.*\\*/" "" code "${line}")
    string(REGEX REPLACE "/\\*.*$" "" code "${code}")
    string(REGEX REPLACE "//.*$" "" code "${code}")
    if(code MATCHES "^[ \t]*\\*")
      continue()
    endif()
    if(code MATCHES "node[ \t]*->[ \t]*[A-Za-z_]")
      list(APPEND problems "${f}:${n}: a service dereferences the node struct (`node->`): use the accessors of ub/ub_node_svc.h")
    elseif(code MATCHES "(->|\\.)[ \t]*(${node_members_re})[^A-Za-z0-9_]")
      list(APPEND problems "${f}:${n}: a service reads a ub_node_t member (${CMAKE_MATCH_2}): use the accessors of ub/ub_node_svc.h")
    endif()
  endforeach()
endforeach()

# codec/: its own includes, then the closure of the public headers it may use.
file(GLOB codec_files "${CODEC_DIR}/*.c" "${CODEC_DIR}/*.h")
set(public_seen "")
foreach(f ${codec_files})
  math(EXPR checked "${checked} + 1")
  read_lines("${f}" lines)
  set(n 0)
  foreach(line IN LISTS lines)
    math(EXPR n "${n} + 1")
    if(NOT line MATCHES "^[ \t]*#[ \t]*include[ \t]*\"([^\"]+)\"")
      continue()
    endif()
    set(inc "${CMAKE_MATCH_1}")
    if(inc MATCHES "^codec/")
      continue()
    elseif(inc MATCHES "^ub/(.+)$")
      list(FIND wire_headers "${CMAKE_MATCH_1}" at)
      if(at LESS 0)
        list(APPEND problems "${f}:${n}: the wire layer includes ${inc}, a header above it (allowed: ${wire_headers})")
      endif()
    else()
      list(APPEND problems "${f}:${n}: the wire layer includes \"${inc}\": only codec/ and the wire layer's public headers")
    endif()
  endforeach()
endforeach()
foreach(h ${wire_headers})
  if(NOT EXISTS "${INC}/ub/${h}")
    continue()
  endif()
  read_lines("${INC}/ub/${h}" lines)
  set(n 0)
  foreach(line IN LISTS lines)
    math(EXPR n "${n} + 1")
    if(line MATCHES "^[ \t]*#[ \t]*include[ \t]*\"(ub/)?([^\"]+)\"")
      list(FIND wire_headers "${CMAKE_MATCH_2}" at)
      if(at LESS 0)
        list(APPEND problems "${INC}/ub/${h}:${n}: a wire-layer header includes ${CMAKE_MATCH_2}, which is above the wire layer")
      endif()
    endif()
  endforeach()
endforeach()

if(checked LESS 2)
  message(FATAL_ERROR "no source found under ${SVC_DIR} and ${CODEC_DIR}: the check would prove nothing")
endif()
if(problems)
  list(LENGTH problems count)
  string(REPLACE ";" "\n  " listing "${problems}")
  string(REPLACE "<semi>" ";" listing "${listing}")
  string(REPLACE "<lb>" "[" listing "${listing}")
  string(REPLACE "<rb>" "]" listing "${listing}")
  message(FATAL_ERROR "layering broken (${count}):\n  ${listing}")
endif()
message(STATUS "layers hold: ${checked} files of svc/ and codec/")
