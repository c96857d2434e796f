"""Independent fixed point of fuzzy c-means (Zhang et al. 2018, eqs. 5-6, m = 2) for the unit test
`fcm::tests::fcm_converges_to_known_centres`. Plain Python, no dependencies.

Run: python3 crates/targets/tests/data/fcm_reference.py
Prints: [-1.6259e-06, 5.0000015, 20.0000001] (approximately)
"""
x = [-0.1, 0.0, 0.1, 4.9, 5.0, 5.1, 19.9, 20.0, 20.1]
v = [1.0, 7.0, 15.0]
for _ in range(2000):
    U = []
    for xj in x:
        d = [(xj - vi) ** 2 for vi in v]
        if 0.0 in d:
            u = [1.0 if di == 0.0 else 0.0 for di in d]
        else:
            w = [1.0 / di for di in d]
            s = sum(w)
            u = [wi / s for wi in w]
        U.append(u)
    v = [
        sum(U[j][i] ** 2 * x[j] for j in range(len(x))) / sum(U[j][i] ** 2 for j in range(len(x)))
        for i in range(3)
    ]
print(v)
