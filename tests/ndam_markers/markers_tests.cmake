# Free-surface marker tests (included from tests/CMakeLists.txt). The serial cases are discovered
# one by one; the MarkersMpi cases also run under mpiexec with 2 ranks, where each rank compares
# the distributed marker set with a serial one on MPI_COMM_SELF.
add_executable(test_markers ${CMAKE_CURRENT_LIST_DIR}/test_markers.cpp)
target_link_libraries(test_markers PRIVATE granflow_markers GTest::gtest granflow_warnings)
gtest_discover_tests(test_markers DISCOVERY_TIMEOUT 60 PROPERTIES LABELS "markers")
add_test(NAME markers.mpi_np2
         COMMAND ${MPIEXEC_EXECUTABLE} --allow-run-as-root --oversubscribe ${MPIEXEC_NUMPROC_FLAG} 2
                 $<TARGET_FILE:test_markers> --gtest_filter=MarkersMpi.*)
set_tests_properties(markers.mpi_np2 PROPERTIES LABELS "markers;mpi" TIMEOUT 120)
