# The ROS 2 wheels on PyPI export cmake targets whose include folders name the
# machine that built them (/opt/python/...); cmake refuses such targets at the
# generate step. A system ROS 2 install has none, so this is a no-op there.
get_property(_swazure_targets DIRECTORY PROPERTY IMPORTED_TARGETS)
foreach(_target IN LISTS _swazure_targets)
  get_target_property(_dirs ${_target} INTERFACE_INCLUDE_DIRECTORIES)
  if(_dirs)
    set(_kept "")
    foreach(_dir IN LISTS _dirs)
      if(_dir MATCHES "^\\$<" OR EXISTS "${_dir}")
        list(APPEND _kept "${_dir}")
      endif()
    endforeach()
    set_target_properties(${_target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${_kept}")
  endif()
endforeach()
