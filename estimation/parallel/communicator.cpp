#include "estimation/parallel/communicator.h"

#include <atomic>

namespace sigmaheart::estimation::parallel {

int Communicator::broadcast(int value, int root) {
  broadcast(std::span<int>(&value, 1), root);
  return value;
}

std::string Communicator::broadcast(const std::string& text, int root) {
  const int length = broadcast(static_cast<int>(text.size()), root);
  std::string out = rank() == root ? text : std::string(static_cast<size_t>(length), '\0');
  broadcast(std::as_writable_bytes(std::span<char>(out.data(), out.size())), root);
  return out;
}

std::vector<std::vector<std::byte>> SerialCommunicator::all_gather(
    std::span<const std::byte> local) {
  return {std::vector<std::byte>(local.begin(), local.end())};
}

namespace {

class AtomicCounter final : public SharedCounter {
 public:
  long fetch_add(long increment) override { return value_.fetch_add(increment); }

 private:
  std::atomic<long> value_{0};
};

}  // namespace

std::unique_ptr<SharedCounter> SerialCommunicator::make_counter() {
  return std::make_unique<AtomicCounter>();
}

}  // namespace sigmaheart::estimation::parallel
