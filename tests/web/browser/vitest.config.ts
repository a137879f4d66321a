// Browser tests of the viewer: headless Chromium (Debian's /usr/bin/chromium) driven by
// playwright-core, against `sonolux serve` on a bundle baked for the run. Run by
// tests/web/run.sh (make test-web), with the vitest of web/node_modules:
//   web/node_modules/.bin/vitest run --root tests/web/browser
export default {
  cacheDir: '../../../web/node_modules/.vite-browser-tests', // not a node_modules/ under tests/
  test: {
    include: ['*.test.ts'],
    globalSetup: ['./global-setup.ts'],
    testTimeout: 120_000,
    hookTimeout: 300_000,
    fileParallelism: false,
    pool: 'forks',
  },
};
