# Test of cmake/git_describe.cmake (run with cmake -P; SCRIPT: that script, WORK: a scratch
# directory). Results carry the git description of the code that made them: the script must give
# the commit of the tree it is run on, "-dirty" for uncommitted changes, follow new commits, leave
# its output untouched when the description has not changed (so an unchanged tree rebuilds
# nothing), and say "unknown" outside a repository.
find_program(GIT git REQUIRED)
file(REMOVE_RECURSE "${WORK}")
file(MAKE_DIRECTORY "${WORK}/repo" "${WORK}/plain")
set(OUT "${WORK}/git_describe.cpp")
# The scratch directory lies inside the build tree, which may lie inside a checkout: git must not
# look above WORK for a repository.
set(ENV{GIT_CEILING_DIRECTORIES} "${WORK}")

function(git)
  execute_process(COMMAND "${GIT}" -c user.name=test -c user.email=test@example.org ${ARGN}
                  WORKING_DIRECTORY "${WORK}/repo" RESULT_VARIABLE rc OUTPUT_QUIET ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "git ${ARGN} failed: ${err}")
  endif()
endfunction()
function(head_hash var)
  execute_process(COMMAND "${GIT}" rev-parse --short HEAD WORKING_DIRECTORY "${WORK}/repo"
                  OUTPUT_VARIABLE h OUTPUT_STRIP_TRAILING_WHITESPACE)
  set(${var} "${h}" PARENT_SCOPE)
endfunction()
function(describe_in src expected)
  execute_process(COMMAND "${CMAKE_COMMAND}" -DSRC=${src} -DOUT=${OUT} -P "${SCRIPT}" RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${SCRIPT} failed in ${src}")
  endif()
  file(READ "${OUT}" text)
  string(FIND "${text}" "kGitDescribe = \"${expected}\";" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "expected the description '${expected}' in ${OUT}, got:\n${text}")
  endif()
endfunction()

git(init -q)
file(WRITE "${WORK}/repo/a.txt" "one\n")
git(add a.txt)
git(commit -q -m one)
head_hash(first)
describe_in("${WORK}/repo" "${first}")

# Unchanged description: the file is not rewritten (its old modification time stays).
execute_process(COMMAND touch -d "2001-01-01 00:00:00" "${OUT}")
describe_in("${WORK}/repo" "${first}")
file(TIMESTAMP "${OUT}" stamp "%Y" UTC)
if(NOT stamp STREQUAL "2001")
  message(FATAL_ERROR "${OUT} was rewritten although the description did not change (year ${stamp})")
endif()

# Uncommitted changes, then a new commit.
file(WRITE "${WORK}/repo/a.txt" "two\n")
describe_in("${WORK}/repo" "${first}-dirty")
git(commit -q -a -m two)
head_hash(second)
if(second STREQUAL first)
  message(FATAL_ERROR "the second commit has the first one's hash")
endif()
describe_in("${WORK}/repo" "${second}")

# Outside a repository.
describe_in("${WORK}/plain" "unknown")
message(STATUS "git_describe.cmake: ${first}, ${first}-dirty, ${second}, unknown")
