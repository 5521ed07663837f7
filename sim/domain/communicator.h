#pragma once
// The collective operations a decomposed run needs, behind a small interface: MPI
// (MPI_COMM_WORLD) in a build with MPI, launched by mpirun; nothing else in sim/ includes mpi.h.
// Every call is collective: every rank makes the same calls in the same order.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

namespace mesorock::sim {

class Communicator {
 public:
  virtual ~Communicator() = default;
  virtual int rank() const = 0;
  virtual int size() const = 0;
  virtual void sum(double* values, int count) = 0;  // in place
  virtual void max(double* values, int count) = 0;
  virtual void min(std::uint64_t* values, int count) = 0;
  virtual void sum(std::uint64_t* values, int count) = 0;
  // Each rank sends send[r] (bytes) to rank r and receives what every rank sent it, in rank
  // order, into recv; recv_bytes[r] says how much came from r.
  virtual void alltoallv(const std::vector<std::vector<char>>& send, std::vector<char>& recv,
                         std::vector<int>& recv_bytes) = 0;
  // Every rank's bytes, concatenated in rank order, on every rank. Any size: MPI counts are int,
  // so gathers of more than 2 GiB in all (a checkpoint of 10^8 particles) go in rounds.
  virtual void allgatherv(const std::vector<char>& mine, std::vector<char>& all,
                          std::vector<std::size_t>& bytes_per_rank) = 0;
  virtual void barrier() = 0;
  // The most bytes one round of allgatherv moves in all (2^30; tests set it small to run the
  // rounds on small data).
  void set_gather_round_bytes(std::size_t bytes) { gather_round_bytes_ = bytes; }

  // Typed helpers over trivially copyable records.
  template <class T>
  void alltoallv_records(const std::vector<std::vector<T>>& send, std::vector<T>& recv,
                         std::vector<int>& recv_counts) {
    std::vector<std::vector<char>> bytes(send.size());
    for (size_t r = 0; r < send.size(); ++r) {
      const char* p = reinterpret_cast<const char*>(send[r].data());
      bytes[r].assign(p, p + send[r].size() * sizeof(T));
    }
    std::vector<char> in;
    std::vector<int> in_bytes;
    alltoallv(bytes, in, in_bytes);
    recv.resize(in.size() / sizeof(T));
    if (!in.empty()) std::memcpy(recv.data(), in.data(), in.size());
    recv_counts.resize(in_bytes.size());
    for (size_t r = 0; r < in_bytes.size(); ++r)
      recv_counts[r] = in_bytes[r] / static_cast<int>(sizeof(T));
  }
  template <class T>
  std::vector<T> allgather_records(const std::vector<T>& mine) {
    const char* p = reinterpret_cast<const char*>(mine.data());
    std::vector<char> bytes(p, p + mine.size() * sizeof(T)), all;
    std::vector<std::size_t> per_rank;
    allgatherv(bytes, all, per_rank);
    std::vector<T> out(all.size() / sizeof(T));
    if (!all.empty()) std::memcpy(out.data(), all.data(), all.size());
    return out;
  }

 protected:
  std::size_t gather_round_bytes_ = std::size_t{1} << 30;
};

// Starts MPI when this process was launched by mpirun (Open MPI's or PMI's environment is set)
// and this build has MPI; finalises it on destruction. world() is null otherwise: a plain run
// pays nothing for MPI, not even MPI_Init.
class MpiSession {
 public:
  MpiSession(int* argc, char*** argv);
  ~MpiSession();
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;
  std::shared_ptr<Communicator> world() const { return world_; }
  // Aborts every rank (after a rank failed alone: the others would wait forever).
  static void abort(int code);

 private:
  bool started_ = false;
  std::shared_ptr<Communicator> world_;
};

// One rank without MPI: what `rockflow bench --decompose` runs the decomposed solver over, to
// measure what its machinery costs against the plain single-rank path.
std::shared_ptr<Communicator> make_self_communicator();

// Whether this build has MPI ("" if yes, else why not).
std::string mpi_unavailable_reason();

}  // namespace mesorock::sim
