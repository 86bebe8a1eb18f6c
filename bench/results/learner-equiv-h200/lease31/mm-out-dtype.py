# bf16 weight/bias gradient products: mm then cast, against mm with out_dtype float32
import torch
torch.backends.cuda.matmul.allow_tf32 = True
dev = "cuda"
mb = 8192
def t(f, n=50, reps=10):  # microseconds per call, replayed from a CUDA graph of n calls
    st = torch.cuda.Stream()
    st.wait_stream(torch.cuda.current_stream())
    with torch.cuda.stream(st):
        for _ in range(5): f()
    torch.cuda.current_stream().wait_stream(st)
    g = torch.cuda.CUDAGraph()
    with torch.cuda.graph(g):
        for _ in range(n): f()
    g.replay(); torch.cuda.synchronize()
    s, e = torch.cuda.Event(enable_timing=True), torch.cuda.Event(enable_timing=True)
    s.record()
    for _ in range(reps): g.replay()
    e.record(); torch.cuda.synchronize()
    return s.elapsed_time(e) / (n * reps) * 1000
mmd = torch.ops.aten.mm.dtype
print(torch.__version__, torch.cuda.get_device_name())
for task, d, a in (("hand_over", 400, 40), ("catch_abreast", 424, 56)):
    tot = [0.0, 0.0, 0.0, 0.0]
    for net, shapes in (("actor", [(d, 1024), (1024, 1024), (1024, 512), (512, a)]),
                        ("critic", [(d, 1024), (1024, 1024), (1024, 512), (512, 8)])):
        for i, o in shapes:
            x = torch.randn(mb, i, device=dev).bfloat16()
            dy = torch.randn(mb, o, device=dev).bfloat16()
            ones = torch.ones(1, mb, device=dev).bfloat16()
            w_old = t(lambda: dy.t().mm(x).float())
            w_new = t(lambda: mmd(dy.t(), x, torch.float32))
            b_old = t(lambda: ones.mm(dy).float())
            b_new = t(lambda: mmd(ones, dy, torch.float32))
            for k, v in enumerate((w_old, w_new, b_old, b_new)): tot[k] += v
            print(f"{task} {net} [{i}->{o}]: dW mm+cast {w_old:.1f} us, mm f32 out {w_new:.1f} us; "
                  f"db mm+cast {b_old:.1f} us, mm f32 out {b_new:.1f} us")
    print(f"{task} total: dW {tot[0]:.1f} -> {tot[1]:.1f} us, db {tot[2]:.1f} -> {tot[3]:.1f} us")
