# Turns tests/vectors/inspect.json into a C header for test_inspect_vectors.c.
# Run as a build step (see runtime_c/tests/inspect.cmake):
#   cmake -DIN=inspect.json -DOUT=ub_inspect_vectors.h -P inspect_vectors_to_c.cmake
# Each vector becomes its kind's integer fields n[] and byte fields blob[] in the order of the JSON's
# "layouts", plus the expected payload bytes. Plain CMake: the C build needs no Python to read the vectors.
cmake_minimum_required(VERSION 3.20)
if(NOT IN OR NOT OUT)
  message(FATAL_ERROR "usage: cmake -DIN=inspect.json -DOUT=header.h -P inspect_vectors_to_c.cmake")
endif()

file(READ "${IN}" json)
get_filename_component(in_name "${IN}" NAME)
include(${CMAKE_CURRENT_LIST_DIR}/vectors_common.cmake)

string(JSON count LENGTH "${json}" vectors)
math(EXPR last "${count} - 1")
set(arrays "")
set(rows "")
foreach(i RANGE ${last})
  string(JSON name GET "${json}" vectors ${i} name)
  string(JSON kind GET "${json}" vectors ${i} layout)
  string(JSON n_ints LENGTH "${json}" layouts ${kind} ints)
  string(JSON n_blobs LENGTH "${json}" layouts ${kind} bytes)
  set(ints "")
  math(EXPR last_int "${n_ints} - 1")
  foreach(k RANGE ${last_int})
    string(JSON key GET "${json}" layouts ${kind} ints ${k})
    string(JSON v GET "${json}" vectors ${i} ${key})
    string(APPEND ints "${v}u, ")
  endforeach()
  set(blobs "")
  set(lens "")
  math(EXPR last_blob "${n_blobs} - 1")
  foreach(k RANGE ${last_blob})
    string(JSON key GET "${json}" layouts ${kind} bytes ${k})
    string(JSON hex GET "${json}" vectors ${i} ${key})
    hex_to_c("${hex}" c)
    hex_len("${hex}" n)
    string(APPEND arrays "static const uint8_t vec${i}_blob${k}[] = {${c}};\n")
    string(APPEND blobs "vec${i}_blob${k}, ")
    string(APPEND lens "${n}u, ")
  endforeach()
  string(JSON hex GET "${json}" vectors ${i} bytes)
  hex_to_c("${hex}" c)
  hex_len("${hex}" n)
  string(APPEND arrays "static const uint8_t vec${i}_bytes[] = {${c}};\n")
  string(APPEND rows "    {\"${name}\", \"${kind}\", {${ints}}, {${blobs}}, {${lens}}, vec${i}_bytes, ${n}u},\n")
endforeach()

set(text "/* Generated from tests/vectors/${in_name} by runtime_c/tools/inspect_vectors_to_c.cmake. Do not edit. */
#ifndef UB_INSPECT_VECTORS_H
#define UB_INSPECT_VECTORS_H
#include <stddef.h>
#include <stdint.h>

typedef struct inspect_vector {
    const char *name;
    const char *kind;          /* request, value, entity, link, pubsub, admin */
    uint32_t n[8];             /* the kind's integer fields, in the order of inspect.json's \"layouts\" */
    const uint8_t *blob[3];    /* the kind's byte fields */
    size_t blob_len[3];
    const uint8_t *bytes;      /* the payload the reference wrote */
    size_t len;
} inspect_vector_t;

${arrays}
static const inspect_vector_t inspect_vectors[] = {
${rows}};
#define INSPECT_VECTOR_COUNT (sizeof inspect_vectors / sizeof inspect_vectors[0])
#endif
")
file(WRITE "${OUT}" "${text}")
