# Checker for the portaslam CLI tests (run as a script, see features.cmake): runs a command and
# requires its exit status AND the text on the stream the user reads (errors on stderr, results on
# stdout). ctest alone cannot require both: PASS_REGULAR_EXPRESSION ignores the exit status.
#
#   cmake -DEXPECT_EXIT=N [-DEXPECT_STDOUT=regex] [-DEXPECT_STDERR=regex] [-DEXPECT_FILE=path]
#         -P check_cli_output.cmake -- COMMAND [ARGS...]
#
# tests/CMakeLists.txt includes every tests/cli/*.cmake while configuring; this file defines
# nothing then.
if(NOT CMAKE_SCRIPT_MODE_FILE)
  return()
endif()

set(command "")
set(after_separator FALSE)
math(EXPR last "${CMAKE_ARGC} - 1")
foreach(i RANGE ${last})
  if(after_separator)
    list(APPEND command "${CMAKE_ARGV${i}}")
  elseif(CMAKE_ARGV${i} STREQUAL "--")
    set(after_separator TRUE)
  endif()
endforeach()
if(NOT command)
  message(FATAL_ERROR "check_cli_output: no command after --")
endif()

if(EXPECT_FILE)
  file(REMOVE "${EXPECT_FILE}")
endif()
execute_process(COMMAND ${command} RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
message("---- stdout ----\n${out}---- stderr ----\n${err}---- exit status ${status}")

set(problems "")
if(NOT status STREQUAL "${EXPECT_EXIT}")
  string(APPEND problems "  exit status ${status}, expected ${EXPECT_EXIT}\n")
endif()
if(DEFINED EXPECT_STDOUT AND NOT EXPECT_STDOUT STREQUAL "" AND NOT out MATCHES "${EXPECT_STDOUT}")
  string(APPEND problems "  stdout does not match: ${EXPECT_STDOUT}\n")
endif()
if(DEFINED EXPECT_STDERR AND NOT EXPECT_STDERR STREQUAL "" AND NOT err MATCHES "${EXPECT_STDERR}")
  string(APPEND problems "  stderr does not match: ${EXPECT_STDERR}\n")
endif()
if(EXPECT_FILE)
  if(NOT EXISTS "${EXPECT_FILE}")
    string(APPEND problems "  ${EXPECT_FILE} was not written\n")
  else()
    file(SIZE "${EXPECT_FILE}" size)
    if(size EQUAL 0)
      string(APPEND problems "  ${EXPECT_FILE} is empty\n")
    endif()
  endif()
endif()
if(problems)
  message(FATAL_ERROR "command: ${command}\n${problems}")
endif()
