# Find SuiteSparse CHOLMOD (Debian 12 ships 5.12 without a CMake config).
# Defines CHOLMOD::CHOLMOD. BLAS comes from the system alternative (OpenBLAS pthread on our machines).
find_path(CHOLMOD_INCLUDE_DIR cholmod.h PATH_SUFFIXES suitesparse)
find_library(CHOLMOD_LIBRARY cholmod)
find_library(SUITESPARSE_CONFIG_LIBRARY suitesparseconfig)
find_library(CHOLMOD_AMD_LIBRARY amd)
find_library(CHOLMOD_COLAMD_LIBRARY colamd)
find_library(CHOLMOD_OPENBLAS_LIBRARY openblas)

include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(CHOLMOD REQUIRED_VARS CHOLMOD_LIBRARY CHOLMOD_INCLUDE_DIR
  SUITESPARSE_CONFIG_LIBRARY CHOLMOD_AMD_LIBRARY CHOLMOD_COLAMD_LIBRARY)

if(CHOLMOD_FOUND AND NOT TARGET CHOLMOD::CHOLMOD)
  add_library(CHOLMOD::CHOLMOD UNKNOWN IMPORTED)
  set(_cholmod_links ${CHOLMOD_AMD_LIBRARY} ${CHOLMOD_COLAMD_LIBRARY} ${SUITESPARSE_CONFIG_LIBRARY})
  if(CHOLMOD_OPENBLAS_LIBRARY)
    # Linked directly so that openblas_set_num_threads is available to pin BLAS threads.
    list(APPEND _cholmod_links ${CHOLMOD_OPENBLAS_LIBRARY})
  endif()
  set_target_properties(CHOLMOD::CHOLMOD PROPERTIES
    IMPORTED_LOCATION "${CHOLMOD_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${CHOLMOD_INCLUDE_DIR}"
    INTERFACE_LINK_LIBRARIES "${_cholmod_links}")
endif()
mark_as_advanced(CHOLMOD_INCLUDE_DIR CHOLMOD_LIBRARY SUITESPARSE_CONFIG_LIBRARY CHOLMOD_AMD_LIBRARY
  CHOLMOD_COLAMD_LIBRARY CHOLMOD_OPENBLAS_LIBRARY)
