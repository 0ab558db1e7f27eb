# Turns tests/vectors/frames.json into a C header for test_frame_vectors.c.
# Run as a build step (see runtime_c/tests/frame.cmake):
#   cmake -DIN=frames.json -DOUT=ub_frame_vectors.h -P frame_vectors_to_c.cmake
# Plain CMake, so the C build needs no Python to read the vectors.
cmake_minimum_required(VERSION 3.20)
if(NOT IN OR NOT OUT)
  message(FATAL_ERROR "usage: cmake -DIN=frames.json -DOUT=header.h -P frame_vectors_to_c.cmake")
endif()

file(READ "${IN}" json)
get_filename_component(in_name "${IN}" NAME)

include(${CMAKE_CURRENT_LIST_DIR}/vectors_common.cmake)

string(JSON check_input GET "${json}" crc32c_check input)
string(JSON check_crc GET "${json}" crc32c_check crc32c)
hex_to_c("${check_input}" check_bytes)
string(LENGTH "${check_input}" check_hex_len)
math(EXPR check_len "${check_hex_len} / 2")

string(JSON count LENGTH "${json}" vectors)
math(EXPR last "${count} - 1")

set(arrays "")
set(rows "")
foreach(i RANGE ${last})
  foreach(key name dir_id dest_id src_id admin hop_limit seq fingerprint payload hdr_check msg_crc frame)
    string(JSON ${key} GET "${json}" vectors ${i} ${key})
  endforeach()
  foreach(key dir_id dest_id src_id payload frame)
    hex_to_c("${${key}}" ${key}_c)
  endforeach()
  string(LENGTH "${payload}" payload_hex_len)
  math(EXPR payload_len "${payload_hex_len} / 2")
  string(LENGTH "${frame}" frame_hex_len)
  math(EXPR frame_len "${frame_hex_len} / 2")
  string(APPEND arrays "static const uint8_t vec${i}_payload[] = {${payload_c}};\n")
  string(APPEND arrays "static const uint8_t vec${i}_frame[] = {${frame_c}};\n")
  string(APPEND rows "    {\"${name}\", {${dir_id_c}}, {${dest_id_c}}, {${src_id_c}}, ${admin}u, ${hop_limit}u, ${seq}u, ${fingerprint}u,\n")
  string(APPEND rows "     vec${i}_payload, ${payload_len}u, ${hdr_check}u, ${msg_crc}u, vec${i}_frame, ${frame_len}u},\n")
endforeach()

set(text "/* Generated from tests/vectors/${in_name} by runtime_c/tools/frame_vectors_to_c.cmake. Do not edit. */
#ifndef UB_FRAME_VECTORS_H
#define UB_FRAME_VECTORS_H
#include <stddef.h>
#include <stdint.h>

typedef struct frame_vector {
    const char *name;
    uint8_t dir_id[16];
    uint8_t dest_id[12];
    uint8_t src_id[12];
    uint8_t admin;
    uint8_t hop_limit;
    uint32_t seq;
    uint32_t fingerprint;
    const uint8_t *payload;
    size_t payload_len;
    uint8_t hdr_check;
    uint32_t msg_crc;
    const uint8_t *frame;
    size_t frame_len;
} frame_vector_t;

static const uint8_t crc32c_check_input[] = {${check_bytes}};
#define CRC32C_CHECK_LEN ${check_len}u
#define CRC32C_CHECK_VALUE ${check_crc}u

${arrays}
static const frame_vector_t frame_vectors[] = {
${rows}};
#define FRAME_VECTOR_COUNT ${count}u
#endif
")
file(WRITE "${OUT}" "${text}")
