# Work around the ROS 2 Jazzy PyPI wheels' exported CMake targets.
#
# The wheels are built in a manylinux container, and their imported targets (e.g.
# builtin_interfaces::builtin_interfaces__rosidl_generator_py) list include directories
# such as /opt/python/cp311-cp311/include/python3.11 and that container's numpy headers.
# Those paths do not exist on a user's machine, and CMake's generate step rejects imported
# targets with missing include directories. This function rewrites, on every imported target
# of the current directory, each missing include directory to the real Python / NumPy include
# directory (or drops it). On a native ROS install every path exists and nothing changes.
function(phd_swarm_fix_wheel_include_dirs)
  get_property(_targets DIRECTORY PROPERTY IMPORTED_TARGETS)
  set(_missing_seen FALSE)
  foreach(_target IN LISTS _targets)
    get_target_property(_dirs ${_target} INTERFACE_INCLUDE_DIRECTORIES)
    if(NOT _dirs)
      continue()
    endif()
    set(_fixed "")
    set(_changed FALSE)
    foreach(_dir IN LISTS _dirs)
      if(_dir MATCHES "^\\$<" OR EXISTS "${_dir}")
        list(APPEND _fixed "${_dir}")
        continue()
      endif()
      set(_changed TRUE)
      if(NOT _missing_seen)
        find_package(Python3 REQUIRED COMPONENTS Interpreter Development NumPy)
        set(_missing_seen TRUE)
      endif()
      if(_dir MATCHES "numpy")
        list(APPEND _fixed ${Python3_NumPy_INCLUDE_DIRS})
      elseif(_dir MATCHES "include/python3")
        list(APPEND _fixed ${Python3_INCLUDE_DIRS})
      endif()
    endforeach()
    if(_changed)
      list(REMOVE_DUPLICATES _fixed)
      set_target_properties(${_target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${_fixed}")
      message(STATUS "phd_swarm: rewrote missing include dirs of imported target ${_target}")
    endif()
  endforeach()
endfunction()
