// Minimal reproduction of the UBSan "invalid vptr" report at LCM 1.3.1's lcm-cpp-impl.hpp:88 that
// used to fail the LcmOutbox.* tests in the sanitizer build. NOT part of the build: run it by hand.
//
// It is a GCC 12 -fsanitize=vptr code-generation bug, not a bug in LCM and not a misuse in ftid:
// in a call `(s->obj->*s->pmf)(args)` where `s` points to a polymorphic class and `pmf` is a
// pointer to a non-virtual member function, GCC emits the vptr check of the object expression
// with a pointer that is loaded only on the virtual-PMF branch of the Itanium PMF dispatch, and
// checks it on the join of both branches. For a non-virtual PMF it checks an uninitialised
// register, so UBSan reports "invalid vptr", "null pointer" or "misaligned address" depending on
// what that register held; with -fsanitize=address as well, the check's own load through that
// garbage pointer may instead be reported by ASan (e.g. stack-buffer-underflow at the same line).
// The program itself is correct: without sanitizers, with -fsanitize=address alone or with
// -fno-sanitize=vptr it prints n=1 and exits 0.
// LCM's member-function subscription, `LCM::subscribe(channel, &Class::method, object)`, calls
// the handler exactly like that (lcm-cpp-impl.hpp:88, `LCMMHSubscription::cb_func`), with `subs`
// an `lcm::Subscription` (polymorphic: virtual destructor). `subscribeFunction` (a plain function
// pointer plus context, `LCMTypedSubscription::cb_func`) has no PMF call and is not affected, so
// ftid subscribes with that form.
//
//   g++ -std=c++17 -g -fsanitize=vptr -fno-sanitize-recover=vptr gcc_vptr_pmf_repro.cpp && ./a.out
//     -> gcc_vptr_pmf_repro.cpp:45:16: runtime error: member access within address ... which does
//        not point to an object of type 'S' ... invalid vptr            (exit 1)
//   the same with -DCOPY_FIRST (copy s->obj and s->pmf into locals first): n=1, exit 0
//   the same with -DWITH_LCM -I<build>/lcmtypes/gen ... -llcm: LCM's member-function subscription
//     over memq:// reports at lcm-cpp-impl.hpp:88:20; add -DCOPY_FIRST for subscribeFunction: exit 0
// Seen with g++ (Debian 12.2.0-14+deb12u1) 12.2.0 at -O0 and -O2.
#include <cstdio>

#ifndef WITH_LCM
struct Base {
  virtual ~Base() = default;  // makes S polymorphic, like lcm::Subscription
};
struct Handler {  // not polymorphic
  int n = 0;
  void on(int v) { n += v; }
};
struct S : Base {
  Handler* obj = nullptr;
  void (Handler::*pmf)(int) = nullptr;
};

__attribute__((noinline)) void call(void* user_data) {
  S* s = static_cast<S*>(user_data);  // a valid object of dynamic type S
#ifndef COPY_FIRST
  (s->obj->*s->pmf)(1);  // the shape of lcm-cpp-impl.hpp:88
#else
  Handler* obj = s->obj;
  void (Handler::*pmf)(int) = s->pmf;
  (obj->*pmf)(1);
#endif
}

int main() {
  Handler h;
  S s;
  s.obj = &h;
  s.pmf = &Handler::on;
  call(&s);
  std::printf("n=%d (expected 1)\n", h.n);
  return h.n == 1 ? 0 : 1;
}

#else  // WITH_LCM
#include <lcm/lcm-cpp.hpp>
#include <ftid_lcm/command_t.hpp>

struct Handler {
  int n = 0;
  void on(const lcm::ReceiveBuffer*, const std::string&, const ftid_lcm::command_t* m) {
    n += static_cast<int>(m->request_id);
  }
  static void onFn(const lcm::ReceiveBuffer* rb, const std::string& ch,
                   const ftid_lcm::command_t* m, Handler* self) {
    self->on(rb, ch, m);
  }
};

int main() {
  lcm::LCM lc("memq://");
  Handler h;
#ifndef COPY_FIRST
  lc.subscribe("C", &Handler::on, &h);  // LCMMHSubscription: reported at lcm-cpp-impl.hpp:88
#else
  lc.subscribeFunction("C", &Handler::onFn, &h);  // LCMTypedSubscription: clean
#endif
  ftid_lcm::command_t c{};
  c.request_id = 1;
  c.argument = "";
  lc.publish("C", &c);
  lc.handleTimeout(100);
  std::printf("n=%d (expected 1)\n", h.n);
  return h.n == 1 ? 0 : 1;
}
#endif
