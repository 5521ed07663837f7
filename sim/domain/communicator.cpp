#include "sim/domain/communicator.h"

#include <algorithm>
#include <cstdlib>
#include <cstring>

#include "mesorock/errors.h"

#if defined(MESOROCK_HAVE_MPI)
// The C API only: Open MPI's and MPICH's C++ bindings would need their own library.
#define OMPI_SKIP_MPICXX 1
#define MPICH_SKIP_MPICXX 1
#include <mpi.h>
#endif

namespace mesorock::sim {

namespace {

bool launched_by_mpirun() {
  for (const char* v : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK", "MV2_COMM_WORLD_SIZE"})
    if (std::getenv(v) != nullptr) return true;
  return false;
}

#if defined(MESOROCK_HAVE_MPI)
void check(int code, const char* what) {
  if (code == MPI_SUCCESS) return;
  char text[MPI_MAX_ERROR_STRING];
  int len = 0;
  MPI_Error_string(code, text, &len);
  throw DeviceError(std::string("MPI error in ") + what + ": " + std::string(text, len));
}

class MpiCommunicator final : public Communicator {
 public:
  MpiCommunicator() {
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
  }
  int rank() const override { return rank_; }
  int size() const override { return size_; }
  void sum(double* v, int n) override {
    check(MPI_Allreduce(MPI_IN_PLACE, v, n, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD), "allreduce");
  }
  void max(double* v, int n) override {
    check(MPI_Allreduce(MPI_IN_PLACE, v, n, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD), "allreduce");
  }
  void min(std::uint64_t* v, int n) override {
    check(MPI_Allreduce(MPI_IN_PLACE, v, n, MPI_UINT64_T, MPI_MIN, MPI_COMM_WORLD), "allreduce");
  }
  void sum(std::uint64_t* v, int n) override {
    check(MPI_Allreduce(MPI_IN_PLACE, v, n, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD), "allreduce");
  }
  void alltoallv(const std::vector<std::vector<char>>& send, std::vector<char>& recv,
                 std::vector<int>& recv_bytes) override {
    std::vector<int> send_bytes(static_cast<size_t>(size_)), sdispl(send_bytes.size()),
        rdispl(send_bytes.size());
    recv_bytes.assign(send_bytes.size(), 0);
    std::vector<char> flat;
    for (int r = 0; r < size_; ++r) {
      sdispl[static_cast<size_t>(r)] = static_cast<int>(flat.size());
      const auto& b = send[static_cast<size_t>(r)];
      send_bytes[static_cast<size_t>(r)] = static_cast<int>(b.size());
      flat.insert(flat.end(), b.begin(), b.end());
    }
    check(
        MPI_Alltoall(send_bytes.data(), 1, MPI_INT, recv_bytes.data(), 1, MPI_INT, MPI_COMM_WORLD),
        "alltoall");
    int total = 0;
    for (int r = 0; r < size_; ++r) {
      rdispl[static_cast<size_t>(r)] = total;
      total += recv_bytes[static_cast<size_t>(r)];
    }
    recv.resize(static_cast<size_t>(total));
    check(MPI_Alltoallv(flat.data(), send_bytes.data(), sdispl.data(), MPI_BYTE, recv.data(),
                        recv_bytes.data(), rdispl.data(), MPI_BYTE, MPI_COMM_WORLD),
          "alltoallv");
  }
  void allgatherv(const std::vector<char>& mine, std::vector<char>& all,
                  std::vector<std::size_t>& per_rank) override {
    const std::uint64_t bytes = mine.size();
    std::vector<std::uint64_t> sizes(static_cast<size_t>(size_), 0);
    check(MPI_Allgather(&bytes, 1, MPI_UINT64_T, sizes.data(), 1, MPI_UINT64_T, MPI_COMM_WORLD),
          "allgather");
    per_rank.assign(sizes.begin(), sizes.end());
    std::vector<std::size_t> start(sizes.size() + 1, 0);  // of each rank's bytes in `all`
    for (size_t r = 0; r < sizes.size(); ++r) start[r + 1] = start[r] + sizes[r];
    all.resize(start.back());
    // Rounds of at most `round` bytes from each rank, so every count and displacement of one
    // round fits an int; one round below 2 GiB in all.
    const std::size_t round = std::max<std::size_t>(1, gather_round_bytes_ / sizes.size());
    const std::uint64_t largest = *std::max_element(sizes.begin(), sizes.end());
    std::vector<char> in;
    std::vector<int> counts(sizes.size()), displ(sizes.size());
    for (std::uint64_t done = 0; done < largest; done += round) {
      int offset = 0;
      for (size_t r = 0; r < sizes.size(); ++r) {
        const std::uint64_t left = sizes[r] > done ? sizes[r] - done : 0;
        counts[r] = static_cast<int>(std::min<std::uint64_t>(left, round));
        displ[r] = offset;
        offset += counts[r];
      }
      in.resize(static_cast<size_t>(offset));
      const int my_count = counts[static_cast<size_t>(rank_)];
      check(MPI_Allgatherv(mine.data() + std::min<std::uint64_t>(done, bytes), my_count, MPI_BYTE,
                           in.data(), counts.data(), displ.data(), MPI_BYTE, MPI_COMM_WORLD),
            "allgatherv");
      for (size_t r = 0; r < sizes.size(); ++r)
        if (counts[r] > 0)
          std::memcpy(all.data() + start[r] + done, in.data() + displ[r],
                      static_cast<size_t>(counts[r]));
    }
  }
  void barrier() override { check(MPI_Barrier(MPI_COMM_WORLD), "barrier"); }

 private:
  int rank_ = 0, size_ = 1;
};
#endif

class SelfCommunicator final : public Communicator {
 public:
  int rank() const override { return 0; }
  int size() const override { return 1; }
  void sum(double*, int) override {}
  void max(double*, int) override {}
  void min(std::uint64_t*, int) override {}
  void sum(std::uint64_t*, int) override {}
  void alltoallv(const std::vector<std::vector<char>>& send, std::vector<char>& recv,
                 std::vector<int>& recv_bytes) override {
    recv = send.at(0);
    recv_bytes.assign(1, static_cast<int>(recv.size()));
  }
  void allgatherv(const std::vector<char>& mine, std::vector<char>& all,
                  std::vector<std::size_t>& bytes_per_rank) override {
    all = mine;
    bytes_per_rank.assign(1, mine.size());
  }
  void barrier() override {}
};

}  // namespace

std::shared_ptr<Communicator> make_self_communicator() {
  return std::make_shared<SelfCommunicator>();
}

MpiSession::MpiSession(int* argc, char*** argv) {
#if defined(MESOROCK_HAVE_MPI)
  if (!launched_by_mpirun()) return;
  int ready = 0;
  MPI_Initialized(&ready);
  if (!ready) {
    MPI_Init(argc, argv);
    started_ = true;
  }
  // Errors come back as codes (thrown as DeviceError) instead of aborting every rank.
  MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_RETURN);
  world_ = std::make_shared<MpiCommunicator>();
#else
  (void)argc;
  (void)argv;
  (void)launched_by_mpirun;
#endif
}

MpiSession::~MpiSession() {
#if defined(MESOROCK_HAVE_MPI)
  world_.reset();
  if (started_) MPI_Finalize();
#endif
}

void MpiSession::abort(int code) {
#if defined(MESOROCK_HAVE_MPI)
  int ready = 0, done = 0;
  MPI_Initialized(&ready);
  MPI_Finalized(&done);
  if (ready && !done) MPI_Abort(MPI_COMM_WORLD, code);
#else
  (void)code;
#endif
}

std::string mpi_unavailable_reason() {
#if defined(MESOROCK_HAVE_MPI)
  return "";
#else
  return "this build has no MPI (libopenmpi-dev was not found when it was configured)";
#endif
}

}  // namespace mesorock::sim
