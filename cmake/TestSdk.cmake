# The SDK as a user gets it (ctest sdk.out_of_tree_example; docs/guide.md's
# out-of-tree section): install this build into a prefix under the build
# folder, check the installed command finds its own plugins, then configure,
# build and test examples/ against the installed package only.
#
# cmake -DBUILD_DIR=... -DSOURCE_DIR=... [-DLAUNCHER=ccache] [-DWERROR=ON]
#       [-DBUILD_CXX_FLAGS=...] [-DBUILD_LINKER_FLAGS=...] -P TestSdk.cmake
foreach(var BUILD_DIR SOURCE_DIR)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "TestSdk.cmake: -D${var}=... is required")
  endif()
endforeach()
set(work ${BUILD_DIR}/sdk-test)
set(prefix ${work}/prefix)
set(example ${work}/example)
file(REMOVE_RECURSE ${work})

function(step what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  message("${out}${err}")
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "sdk: ${what} failed (${rc})")
  endif()
  set(step_output "${out}${err}" PARENT_SCOPE)
endfunction()

step("install" ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix})

# The installed command runs from its RPATH and finds the plugins installed
# beside it, not the build tree's.
step("installed saccade plugins" ${CMAKE_COMMAND} -E env --unset=SACCADE_PLUGIN_PATH ${prefix}/bin/saccade plugins retina)
if(NOT step_output MATCHES "library: ${prefix}/lib[^\n]*/saccade/plugins/saccade_retina.so")
  message(FATAL_ERROR "sdk: the installed saccade did not load its own plugins:\n${step_output}")
endif()

set(flags "-Wall -Wextra -Wpedantic")
if(WERROR)
  string(APPEND flags " -Werror")
endif()
# The build's own compile and link flags: an SDK built with a sanitizer (the
# asan and tsan presets) links only into programs built with it too (an
# uninstrumented test loading an instrumented libsaccade crashed).
string(APPEND flags " ${BUILD_CXX_FLAGS}")
set(configure ${CMAKE_COMMAND} -S ${SOURCE_DIR}/examples -B ${example} -G Ninja -DCMAKE_BUILD_TYPE=Release
  -DCMAKE_PREFIX_PATH=${prefix} "-DCMAKE_CXX_FLAGS=${flags}" "-DCMAKE_EXE_LINKER_FLAGS=${BUILD_LINKER_FLAGS}"
  "-DCMAKE_SHARED_LINKER_FLAGS=${BUILD_LINKER_FLAGS}" "-DCMAKE_MODULE_LINKER_FLAGS=${BUILD_LINKER_FLAGS}")
if(LAUNCHER)
  list(APPEND configure -DCMAKE_CXX_COMPILER_LAUNCHER=${LAUNCHER})
endif()
step("configure examples/" ${configure})
step("build examples/" ${CMAKE_COMMAND} --build ${example})
step("test examples/" ${CMAKE_CTEST_COMMAND} --test-dir ${example} --output-on-failure)
message("sdk: examples/ built and tested against ${prefix}")
